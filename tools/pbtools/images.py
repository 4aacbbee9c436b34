"""Image grids: the reference, each technique's output and its FLIP error map for one frame of one scene,
with a zoomed crop of one region under every image (the layout of the FLIP and ReSTIR papers' figures).

Sources (cells/<cell>/images/): frame_NNNN.png (tonemapped output), reference_NNNN_<class>.png and
flip_NNNN_<class>.png (error map, already colour-mapped by the harness).
"""

from __future__ import annotations

import math
from typing import List, Optional, Tuple

import numpy as np

from . import style
from .figures import Figure, slug
from .rundata import Cell, Run

Crop = Tuple[int, int, int, int]  # x, y, w, h in pixels of the full image


def parse_crop(text: Optional[str]) -> Optional[tuple]:
    """"x,y,w,h" in pixels, or in fractions of the image when all four are in [0, 1] and one is
    fractional. None -> automatic."""
    if not text:
        return None
    parts = [float(t) for t in text.split(",")]
    if len(parts) != 4 or parts[2] <= 0 or parts[3] <= 0 or min(parts) < 0:
        raise ValueError(f"--crop {text!r}: expected x,y,w,h with w,h > 0")
    return tuple(parts)


def resolve_crop(crop: Optional[tuple], width: int, height: int, error_maps: List[np.ndarray]) -> Crop:
    """Pixel crop inside the image. Without a crop, the window of a quarter of each side whose FLIP
    maps are brightest on average: the maps use magma, whose lightness rises with the error, so the
    brightest window is where the techniques err most -- the region a reader wants to see enlarged."""
    if crop is not None:
        x, y, w, h = crop
        if max(crop) <= 1.0 and any(0 < v < 1 for v in crop):
            x, y, w, h = x * width, y * height, w * width, h * height
        x, y = int(round(x)), int(round(y))
        w, h = max(1, int(round(w))), max(1, int(round(h)))
        x, y = min(max(0, x), width - 1), min(max(0, y), height - 1)
        return x, y, min(w, width - x), min(h, height - y)
    w, h = max(1, width // 4), max(1, height // 4)
    maps = [m for m in error_maps if m.shape[0] == height and m.shape[1] == width]
    if not maps:
        return (width - w) // 2, (height - h) // 2, w, h
    lum = np.mean([luminance(m) for m in maps], axis=0)
    # Window sums by a summed-area table.
    sat = np.pad(lum.cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    sums = sat[h:, w:] - sat[:-h, w:] - sat[h:, :-w] + sat[:-h, :-w]
    y, x = np.unravel_index(int(np.argmax(sums)), sums.shape)
    return int(x), int(y), w, h


def luminance(img: np.ndarray) -> np.ndarray:
    if img.ndim == 2:
        return img
    return img[..., 0] * 0.2126 + img[..., 1] * 0.7152 + img[..., 2] * 0.0722


def load(path: Optional[str]) -> Optional[np.ndarray]:
    if not path:
        return None
    import matplotlib.image
    img = matplotlib.image.imread(path)
    if img.dtype == np.uint8:
        img = img.astype(np.float32) / 255.0
    if img.ndim == 3 and img.shape[2] == 4:
        img = img[..., :3]
    return img


def _find(images: dict, kind: str, frame: int, cls: Optional[str]) -> Optional[str]:
    return images.get((kind, frame, cls, "png"))


def choose_frame(cells: List[Cell]) -> Optional[int]:
    """The latest frame with a reference image in most cells (temporal techniques have converged)."""
    counts = {}
    for c in cells:
        for (kind, frame, _, ext) in c.images():
            if kind == "reference" and ext == "png":
                counts.setdefault(frame, set()).add(c.id)
    if not counts:
        return None
    return max(counts, key=lambda f: (len(counts[f]), f))


def image_grid(run: Run, scene: str, crop: Optional[tuple] = None, frame: Optional[int] = None,
               max_cols: int = 6) -> Optional[Figure]:
    cells = run.cells_of(scene)
    frame = frame if frame is not None else choose_frame(cells)
    if frame is None:
        return None
    # Reference: the primary class's reference from the first cell that has one.
    ref_path, ref_class = None, None
    for c in cells:
        imgs = c.images()
        cls = c.primary_class()
        if _find(imgs, "reference", frame, cls):
            ref_path, ref_class = _find(imgs, "reference", frame, cls), cls
            break
    if ref_path is None:
        for c in cells:
            for (kind, f, cls, ext), path in c.images().items():
                if kind == "reference" and f == frame and ext == "png":
                    ref_path, ref_class = path, cls
                    break
            if ref_path:
                break
    reference = load(ref_path)
    if reference is None:
        return None
    height, width = reference.shape[:2]
    panels = [("reference" + (f" ({ref_class})" if ref_class else ""), reference, None, None, None)]
    for c in cells:
        imgs = c.images()
        out = load(_find(imgs, "frame", frame, None))
        cls = c.primary_class() or ref_class
        flip = load(_find(imgs, "flip", frame, cls))
        flip_value = math.nan
        if cls is not None:
            mf, mv = c.metric_series("flip", cls)
            hit = np.nonzero(mf == frame)[0]
            if len(hit):
                flip_value = float(mv[hit[0]])
        status = None
        if not c.ok:
            status = "FAILED" + (f" at frame {c.failed_frame}" if c.failed_frame is not None else "")
        elif out is None:
            status = "no image"
        panels.append((run.label(c), out, flip, flip_value, status))
    box = resolve_crop(crop, width, height, [p[2] for p in panels if p[2] is not None])
    x, y, w, h = box

    ncols = min(max_cols, len(panels))
    blocks = math.ceil(len(panels) / ncols)
    col_w = style.TEXT_WIDTH_IN / ncols
    img_h = col_w * height / width
    crop_h = col_w * h / w
    title_h = 0.48  # two lines of 5.5 pt titles, and the FLIP value under the block above
    ratios = [title_h, img_h, crop_h, img_h] * blocks
    fig, axes = style.new_figure(style.TEXT_WIDTH_IN, sum(ratios) * 1.08, 4 * blocks, ncols,
                                 gridspec_kw={"height_ratios": ratios, "hspace": 0.06, "wspace": 0.04})
    import matplotlib.patches as mpatches
    rows = []
    for i, (label, img, flip, flip_value, status) in enumerate(panels):
        b, col = divmod(i, ncols)
        a_title = axes[4 * b][col]
        a_img, a_crop, a_flip = axes[4 * b + 1][col], axes[4 * b + 2][col], axes[4 * b + 3][col]
        a_title.axis("off")
        for a in (a_img, a_crop, a_flip):
            a.set_xticks([])
            a.set_yticks([])
            a.grid(False)
            for s in a.spines.values():
                s.set_visible(True)
                s.set_linewidth(0.4)
        # Technique on the first line, its setting (or the failure) on the second.
        head, _, rest = label.partition(" (")
        second = status if status else rest.rstrip(")")
        a_title.text(0.5, 0.36, head, ha="center", va="bottom", fontsize=6, transform=a_title.transAxes)
        a_title.text(0.5, 0.3, second, ha="center", va="top", fontsize=5.5,
                     transform=a_title.transAxes,
                     color=style.FAILED_COLOR if status else "#333333", gid=f"panel-status:{i}")
        if img is not None:
            a_img.imshow(img, interpolation="nearest", gid=f"image:{i}")
            a_img.add_patch(mpatches.Rectangle((x - 0.5, y - 0.5), w, h, fill=False, ec="#00FFFF", lw=0.8))
            a_crop.imshow(img[y:y + h, x:x + w], interpolation="nearest")
        else:
            for a in (a_img, a_crop):
                a.text(0.5, 0.5, status or "no image", transform=a.transAxes, ha="center", va="center",
                       fontsize=5.5, color=style.FAILED_COLOR if status else "#777777")
        if flip is not None:
            a_flip.imshow(flip, interpolation="nearest")
            if math.isfinite(flip_value):
                a_flip.set_xlabel(f"FLIP {flip_value:.4f}", fontsize=5.5, labelpad=1)
        elif i == 0:
            a_flip.axis("off")
            a_flip.text(0.5, 0.5, "FLIP error maps\n(magma: dark = low,\nbright = high)", ha="center",
                        va="center", transform=a_flip.transAxes, fontsize=5.5)
        else:
            a_flip.text(0.5, 0.5, "no error map", ha="center", va="center", transform=a_flip.transAxes,
                        fontsize=5.5, color="#777777")
        rows.append([label, status or "ok", frame, flip_value, x, y, w, h])
    for j in range(len(panels), blocks * ncols):
        b, col = divmod(j, ncols)
        for r in range(4):
            axes[4 * b + r][col].axis("off")
    return Figure(f"images_{slug(scene)}", f"{scene}: images at frame {frame}",
                  f"Reference, each cell's output and its FLIP error map at frame {frame}; the second row "
                  f"enlarges the region x={x}, y={y}, {w}x{h} px (cyan box; set it with --crop x,y,w,h).",
                  fig, ["panel", "status", "frame", "flip", "crop_x", "crop_y", "crop_w", "crop_h"], rows,
                  kind="image")
