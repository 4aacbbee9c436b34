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


GRID_WSPACE, GRID_HSPACE = 0.04, 0.06  # between columns and rows, in mean column widths and row heights
TITLE_PT, SETTING_PT = 6.0, 5.5  # the technique; its setting and a failure
TITLE_FILL = 0.94  # of the column's width a title may take: a margin to the next column's title
TITLE_MARGIN_PT = 3.0  # above and below a title
TITLE_CLEARANCE_PT = 10.0  # for the FLIP values printed under the block above
# Where a title may break, the preferred first: between parameters, after a name's "=", inside a
# name, and between any two characters when nothing else fits.
TITLE_BREAKS = (", ", "=", "_", "-", "/", "")


def _figure_height_in(row_heights_in: List[float], hspace: float) -> float:
    """The figure height at which matplotlib's grid gives each row its height in inches (the grid
    shares the subplot area out in proportion to the ratios, less the gaps between rows): a title row
    then holds the lines it was sized for, and an image row its image at the column's width."""
    import matplotlib
    n, total = len(row_heights_in), sum(row_heights_in)
    share = matplotlib.rcParams["figure.subplot.top"] - matplotlib.rcParams["figure.subplot.bottom"]
    return total * (n + hspace * (n - 1)) / (n * share)


def _column_width_in(ncols: int, wspace: float) -> float:
    """The width of one grid column, as matplotlib's subplot parameters will lay it out."""
    import matplotlib
    inner = style.TEXT_WIDTH_IN * (matplotlib.rcParams["figure.subplot.right"]
                                   - matplotlib.rcParams["figure.subplot.left"])
    return inner / (ncols + wspace * (ncols - 1))


def _line_height(size_pt: float) -> float:
    return 1.25 * size_pt


def text_width_pt(text: str, size_pt: float) -> float:
    """The width of a line of text in the report's font, in points."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import text_to_path
    import matplotlib
    prop = FontProperties(family=matplotlib.rcParams["font.family"], size=size_pt)
    return text_to_path.get_text_width_height_descent(text, prop, ismath=False)[0]


def wrap_to_width(text: str, width_pt: float, size_pt: float, breaks=TITLE_BREAKS) -> List[str]:
    """`text` in lines no wider than width_pt at size_pt, broken at the most preferred break (of
    `breaks`) that makes the pieces fit, each line filled as far as it goes. Wrapped, not cut short:
    the end of a setting is what tells two cells of one technique apart."""
    if not text or text_width_pt(text, size_pt) <= width_pt or not breaks:
        return [text]
    sep, finer = breaks[0], breaks[1:]
    if sep:
        parts = text.split(sep)
        pieces = [p + sep for p in parts[:-1]] + [parts[-1]]
    else:
        pieces = list(text)
    if len(pieces) == 1:
        return wrap_to_width(text, width_pt, size_pt, finer)
    lines, line = [], ""
    for piece in pieces:
        if line and text_width_pt((line + piece).rstrip(), size_pt) <= width_pt:
            line += piece
            continue
        if line:
            lines.append(line.rstrip())
        # A piece too wide alone breaks at the next finer break; its last line takes what follows.
        *whole, line = wrap_to_width(piece.rstrip(), width_pt, size_pt, finer) or [""]
        lines += whole
        line += piece[len(piece.rstrip()):]  # the separator's space, should the next piece follow
    lines.append(line.rstrip())
    return [line for line in lines if line]


def _title_lines(title: str, setting: str, status: Optional[str], width_pt: float) -> List[tuple]:
    """(text, size, kind) of a panel's title from top to bottom: the technique, its setting, then
    the failure, each wrapped to the column."""
    lines = [(t, TITLE_PT, "title") for t in wrap_to_width(title, width_pt, TITLE_PT)]
    lines += [(t, SETTING_PT, "setting") for t in wrap_to_width(setting, width_pt, SETTING_PT) if t]
    if status:
        lines += [(t, SETTING_PT, "status") for t in wrap_to_width(status, width_pt, SETTING_PT)]
    return lines


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
    # (label, title, setting, image, error map, FLIP, status): the title names the technique, the
    # setting what tells the cell from the technique's other cells in the scene.
    panels = [("reference" + (f" ({ref_class})" if ref_class else ""), "reference", ref_class or "",
               reference, None, None, None)]
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
        label = run.label(c)
        setting = "" if label == c.technique else run.label(c, with_technique=False)
        panels.append((label, c.technique, setting, out, flip, flip_value, status))
    box = resolve_crop(crop, width, height, [p[4] for p in panels if p[4] is not None])
    x, y, w, h = box

    ncols = min(max_cols, len(panels))
    blocks = math.ceil(len(panels) / ncols)
    style.apply()  # the fonts the titles are measured in, the subplot margins the grid is laid out in
    col_w = _column_width_in(ncols, GRID_WSPACE)
    img_h = col_w * height / width
    crop_h = col_w * h / w
    title_w_pt = col_w * 72 * TITLE_FILL
    titles = [_title_lines(title, setting, status, title_w_pt)
              for _, title, setting, _, _, _, status in panels]
    # A block's title row is as tall as its longest title, under the FLIP values of the block above.
    title_h = [(TITLE_MARGIN_PT + (TITLE_CLEARANCE_PT if b else 0)
                + max(sum(_line_height(size) for _, size, _ in lines)
                      for lines in titles[b * ncols:(b + 1) * ncols])) / 72 for b in range(blocks)]
    ratios = [r for b in range(blocks) for r in (title_h[b], img_h, crop_h, img_h)]
    fig, axes = style.new_figure(style.TEXT_WIDTH_IN, _figure_height_in(ratios, GRID_HSPACE), 4 * blocks,
                                 ncols, gridspec_kw={"height_ratios": ratios, "hspace": GRID_HSPACE,
                                                     "wspace": GRID_WSPACE})
    import matplotlib.patches as mpatches
    rows = []
    for i, (label, _, _, img, flip, flip_value, status) in enumerate(panels):
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
        # Stacked up from the bottom of the title row, so every title sits right above its images.
        rise = TITLE_MARGIN_PT / 2
        for k, (text, size, kind) in reversed(list(enumerate(titles[i]))):
            color = {"title": "black", "setting": "#333333", "status": style.FAILED_COLOR}[kind]
            a_title.annotate(text, (0.5, 0), xycoords="axes fraction", xytext=(0, rise),
                             textcoords="offset points", ha="center", va="bottom", fontsize=size,
                             color=color, gid=f"panel-{kind}:{i}:{k}")
            rise += _line_height(size)
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
