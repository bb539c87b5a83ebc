"""Times the viewer as a person uses it: headless Chromium moves a slider of `sonarproj view`
and the time from the slider's input event to the page having drawn the engine's answer (request,
computation, JSON, 2-D and 3-D drawing) is recorded, for the paper's two preset pairs.

Usage: python scripts/bench_viewer.py [--moves N] [--backend auto|cpu|cpu-fast|gpu]
(needs the release binary, Chromium, chromedriver and selenium, as the test command installs;
SONARPROJ_BIN names another binary)."""

import argparse
import pathlib
import statistics
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "web" / "tests"))
from conftest import Page, Server, chrome  # noqa: E402

SCENES = [
    # pair, feature, place, slider moved (a yaw sweep keeps part of the set visible)
    (("paper-fls", "paper-sss"), (5, 0, 0), (15, 0, 0), "rotation.pitch"),
    (("paper-sss", "paper-fls"), (5, 0, 0), (5, 0, 0), "rotation.yaw"),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--moves", type=int, default=60)
    ap.add_argument("--backend", default="auto")
    args = ap.parse_args()
    server = Server("--backend", args.backend)
    driver = chrome()
    try:
        page = Page(driver, server.url)
        device = driver.execute_script("return document.getElementById('device').textContent")
        print(f"viewer: {device}")
        print("| pair | slider moves | update, median | update, 95th percentile | engine compute, median |")
        print("|---|---|---|---|---|")
        for (first, second), feature, place, slider in SCENES:
            page.select("from", first)
            page.select("to", second)
            for key, v in zip(("feature.range", "feature.azimuth", "feature.elevation"), feature):
                page.type(key, v)
            for key, v in zip(("place.range", "place.azimuth", "place.elevation"), place):
                page.type(key, v)
            for _ in range(5):  # warm-up
                page.slide(slider, 1)
            start = len(driver.execute_script("return window.sonarprojStats.updates"))
            for k in range(args.moves):
                page.slide(slider, -60 + 120 * k / max(1, args.moves - 1))
            updates = driver.execute_script("return window.sonarprojStats.updates")[start:]
            ms = sorted(u["ms"] for u in updates)
            compute = statistics.median(u["compute_ms"] for u in updates)
            p95 = ms[min(len(ms) - 1, round(0.95 * (len(ms) - 1)))]
            print(f"| {first} → {second} | {len(ms)} ({slider}) | {statistics.median(ms):.1f} ms | "
                  f"{p95:.1f} ms | {compute:.2f} ms |")
    finally:
        driver.quit()
        server.stop()


if __name__ == "__main__":
    main()
