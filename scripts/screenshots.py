"""Makes the README's pictures in docs/images: the viewer in headless Chromium (two preset
pairs), a mask picture (`sonarproj mask`) and the paper's figures (`sonarproj paper`, and its smooth
version's range spans with `--step auto`).

Usage: python scripts/screenshots.py [--out docs/images] [--sizes 1400x900,1920x1080] [--viewer-only]
(needs the release binary, Chromium, chromedriver and selenium, as the test command installs;
SONARPROJ_BIN names another binary). The viewer is shot in a window of each size; the first
size's pictures are the README's (viewer-fls-sss.png, viewer-sss-fls.png), the others' names end
in the size (viewer-fls-sss-1920x1080.png)."""

import argparse
import io
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

from PIL import Image

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "web" / "tests"))
from conftest import Page, Server, binary_path, chrome  # noqa: E402


def save(driver, path):
    """Saves the window as a PNG of at most 256 colours (the page's flat colours survive; the
    file is a third of the size)."""
    image = Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("RGB")
    image.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE).save(path, optimize=True)


def viewer_shots(out, sizes):
    server = Server()
    try:
        for k, (width, height) in enumerate(sizes):
            suffix = "" if k == 0 else f"-{width}x{height}"
            driver = chrome(f"--window-size={width},{height}")
            try:
                page = Page(driver, server.url)
                # the paper's first example: FLS feature at 5 m, sidescan pitched 90°, placed at 15 m
                page.slide("rotation.pitch", 90)
                frame(page)
                save(driver, out / f"viewer-fls-sss{suffix}.png")
                # a sidescan feature looked for in an FLS, with noise and the fan seen from above
                page.select("from", "paper-sss")
                page.select("to", "paper-fls")
                page.type("place.range", 5)
                page.type("place.azimuth", 8)
                for key, v in (("rotation.roll", 20), ("rotation.pitch", 30), ("rotation.yaw", 40)):
                    page.slide(key, v)
                page.check("noise-on", True)
                frame(page)
                save(driver, out / f"viewer-sss-fls{suffix}.png")
            finally:
                driver.quit()
    finally:
        server.stop()


def frame(page):
    """Frames the feature as the scene now is ("frame the feature"), as a person would."""
    page.d.execute_script("document.getElementById('fit').click()")
    time.sleep(0.3)


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
        # the smooth version, shown beside the reproduction in docs/paper.md
        subprocess.run([sonarproj, "paper", "--out", tmp, "--step", "auto"], check=True, capture_output=True)
        smooth = pathlib.Path(tmp) / "fls-to-sss-lines.png"
        shutil.copy(smooth, out / "paper-fls-to-sss-lines-smooth.png")
    return figures + [smooth]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "docs" / "images")
    ap.add_argument("--sizes", default="1400x900",
                    help="window sizes of the viewer's pictures, WIDTHxHEIGHT, comma-separated")
    ap.add_argument("--viewer-only", action="store_true", help="only the viewer's pictures")
    args = ap.parse_args()
    sizes = [tuple(int(v) for v in size.split("x")) for size in args.sizes.split(",")]
    args.out.mkdir(parents=True, exist_ok=True)
    viewer_shots(args.out, sizes)
    if not args.viewer_only:
        cli_pictures(args.out)
    for f in sorted(args.out.glob("*.png")):
        print(f)


if __name__ == "__main__":
    main()
