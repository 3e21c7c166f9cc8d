"""Helpers shared by the examples: output folder and image grids."""

import os

import numpy as np

OUT = os.environ.get("PYVR_OUT", os.path.join(os.path.dirname(__file__), "..", "out"))


def out_path(name: str) -> str:
    os.makedirs(OUT, exist_ok=True)
    return os.path.normpath(os.path.join(OUT, name))


def save_grid(images, labels, path, cols=3, background=(20, 20, 28)):
    """Composite RGBA renders (row 0 = bottom, as render() returns them)
    over a dark background into a labelled grid PNG."""
    from PIL import Image, ImageDraw

    h, w = images[0].shape[:2]
    rows = (len(images) + cols - 1) // cols
    sheet = Image.new("RGB", (cols * w, rows * (h + 18)), background)
    draw = ImageDraw.Draw(sheet)
    for i, (img, label) in enumerate(zip(images, labels)):
        rgba = Image.fromarray(np.ascontiguousarray(img[::-1]), "RGBA")
        tile = Image.new("RGB", (w, h), background)
        tile.paste(rgba, mask=rgba.split()[3])
        x, y = (i % cols) * w, (i // cols) * (h + 18)
        sheet.paste(tile, (x, y + 18))
        draw.text((x + 4, y + 3), label, fill=(230, 230, 230))
    sheet.save(path)
    return path
