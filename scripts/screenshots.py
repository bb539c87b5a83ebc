"""Makes the README's pictures in docs/images: the viewer in headless Chromium (two preset
pairs), a mask picture (`sonarproj mask`) and the paper's figures (`sonarproj paper`, and its smooth
version's range spans with `--step auto`).

Usage: python scripts/screenshots.py [--out docs/images]
(needs the release binary, Chromium, chromedriver and selenium, as the test command installs;
SONARPROJ_BIN names another binary)."""

import argparse
import pathlib
import shutil
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "web" / "tests"))
from conftest import Page, Server, binary_path, chrome  # noqa: E402


def viewer_shots(out):
    server = Server()
    driver = chrome("--window-size=1600,1000")
    try:
        page = Page(driver, server.url)
        # the paper's first example: FLS feature at 5 m, sidescan pitched 90°, placed at 15 m
        page.slide("rotation.pitch", 90)
        page.d.execute_script("window.scrollTo(0, 0)")
        driver.save_screenshot(str(out / "viewer-fls-sss.png"))
        # a sidescan feature looked for in an FLS, with noise and the fan seen from above
        page.select("from", "paper-sss")
        page.select("to", "paper-fls")
        page.type("place.range", 5)
        page.type("place.azimuth", 8)
        for key, v in (("rotation.roll", 20), ("rotation.pitch", 30), ("rotation.yaw", 40)):
            page.slide(key, v)
        page.check("noise-on", True)
        page.d.execute_script("window.scrollTo(0, 0)")
        driver.save_screenshot(str(out / "viewer-sss-fls.png"))
    finally:
        driver.quit()
        server.stop()


def cli_pictures(out):
    sonarproj = str(binary_path())
    subprocess.run([sonarproj, "mask", "--from", "holoocean-sidescan", "--to", "holoocean-imaging",
                    "--pitch", "5", "--yaw", "10", "--translation", "0.3,0.2,-0.1",
                    "--feature", "4", "--feature", "7.5",
                    "--out", str(out / "mask-fan.png")], check=True, capture_output=True)
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sonarproj, "paper", "--out", tmp], check=True, capture_output=True)
        figures = sorted(pathlib.Path(tmp).glob("*.png"))
        for f in figures:
            shutil.copy(f, out / f"paper-{f.name}")
    with tempfile.TemporaryDirectory() as tmp:
        # the smooth version, shown beside the reproduction in the README
        subprocess.run([sonarproj, "paper", "--out", tmp, "--step", "auto"], check=True, capture_output=True)
        smooth = pathlib.Path(tmp) / "fls-to-sss-lines.png"
        shutil.copy(smooth, out / "paper-fls-to-sss-lines-smooth.png")
    return figures + [smooth]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "docs" / "images")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    viewer_shots(args.out)
    cli_pictures(args.out)
    for f in sorted(args.out.glob("*.png")):
        print(f)


if __name__ == "__main__":
    main()
