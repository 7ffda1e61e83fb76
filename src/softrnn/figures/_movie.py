"""An animation's frames rendered and written: Agg blitting of a scene's moving artists
(``render_frames``) into a GIF (Pillow, one shared palette, ``GifSink``) or an MP4 (ffmpeg,
``FfmpegSink``), atomically (``write_movie``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.animation import FFMpegWriter
from matplotlib.colors import to_rgb
from PIL import Image

from ..progress import Progress
from .saving import FRAME_DPI as _DPI
from .saving import atomic_output


class GifSink:
    """Collects frames as 8-bit palette images (a quarter of the memory of RGBA) and writes one GIF.

    One palette serves all frames: a median cut of the first frame (which holds every static colour)
    plus gradients from the backgrounds to each moving artist's colour, each entry set to the
    commonest exact colour of its box (so white stays 255, not 252). Frames are mapped onto it by
    exact nearest colour through a lookup table filled as new colours appear (a few ms a frame)."""

    def __init__(self, tmp: str, size: tuple[int, int], fps: float, colors=()):
        self.tmp, self.size, self.fps, self.frames = tmp, size, fps, []
        self.colors = colors
        self.table = None  # (256, 3) palette
        self.lut = None  # packed RGB -> palette index
        self.known = None

    def _make_palette(self, first: np.ndarray) -> None:
        """The shared palette from the first frame and the moving artists' colour ramps."""
        h, w, _ = first.shape
        grounds = [np.array([255.0, 255.0, 255.0]), first[h // 2, w // 2], first[h // 3, w // 3]]
        ramp = np.linspace(0.0, 1.0, 32)[:, None]
        strips = [(1 - ramp) * g + ramp * 255 * np.array(to_rgb(c)) for c in self.colors for g in grounds]
        swatch = np.concatenate(strips).round().astype(np.uint8)
        # repeated so that median cut (which splits by pixel count) gives the ramps about a third
        # of the palette instead of lumping them with the static colours
        reps = max(1, (h * w) // (2 * len(swatch)))
        swatch = np.repeat(swatch, reps, axis=0)
        rows = -(-len(swatch) // w)
        pad = np.full((rows * w - len(swatch), 3), 255, dtype=np.uint8)
        extra = np.concatenate([swatch, pad]).reshape(rows, w, 3)
        sheet = np.concatenate([first, extra])
        pal = Image.fromarray(sheet).quantize(colors=256, method=Image.Quantize.MEDIANCUT,
                                              dither=Image.Dither.NONE)
        idx = np.asarray(pal, dtype=np.int64).ravel()
        code = pack_rgb(sheet).ravel()
        table = np.zeros((256, 3), dtype=np.int64)
        given = np.array(pal.getpalette() or [], dtype=np.int64)[:768]
        table.ravel()[:given.size] = given
        pairs, counts = np.unique(idx * (1 << 24) + code, return_counts=True)
        order = np.lexsort((-counts, pairs >> 24))
        firsts = np.unique(pairs[order] >> 24, return_index=True)[1]
        for pair in pairs[order][firsts]:
            k, c = int(pair >> 24), int(pair & 0xFFFFFF)
            table[k] = (c >> 16, (c >> 8) & 255, c & 255)
        self.table = table
        self.lut = np.zeros(1 << 24, dtype=np.uint8)
        self.known = np.zeros(1 << 24, dtype=bool)

    def _indices(self, rgb: np.ndarray) -> np.ndarray:
        """Palette indices of an (H, W, 3) frame; new colours are looked up and remembered."""
        code = pack_rgb(rgb)
        new = np.unique(code[~self.known[code]])
        for k in range(0, new.size, 2048):
            part = new[k:k + 2048]
            cols = np.stack([part >> 16, (part >> 8) & 255, part & 255], axis=1)
            self.lut[part] = ((cols[:, None, :] - self.table[None, :, :]) ** 2).sum(-1).argmin(1)
            self.known[part] = True
        return self.lut[code]

    def add(self, rgba) -> None:
        """Append one RGBA frame, mapped onto the shared palette."""
        rgb = np.asarray(rgba)[..., :3]
        if self.table is None:
            self._make_palette(rgb)
        index = np.ascontiguousarray(self._indices(rgb))
        im = Image.frombuffer("P", self.size, index, "raw", "P", 0, 1)
        im.putpalette(self.table.astype(np.uint8).ravel().tolist())
        self.frames.append(im)

    def finish(self) -> None:
        """Write the GIF to the temporary file."""
        self.frames[0].save(self.tmp, format="GIF", save_all=True, append_images=self.frames[1:],
                            duration=max(20, int(round(1000 / self.fps))), loop=0)

    def abort(self) -> None:
        """Drop the frames."""
        self.frames = []


def pack_rgb(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) uint8 colours as int64 codes r << 16 | g << 8 | b."""
    rgb = rgb.astype(np.int64)
    return (rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]


class FfmpegSink:
    """Pipes raw RGBA frames to ffmpeg (matplotlib's FFMpegWriter builds the command line)."""

    def __init__(self, tmp: str, fig, fps: float):
        self.writer = FFMpegWriter(fps=fps, codec="libx264", extra_args=["-pix_fmt", "yuv420p"])
        self.writer.setup(fig, tmp, dpi=_DPI)

    def add(self, rgba) -> None:
        """Pipe one RGBA frame to ffmpeg."""
        self.writer._proc.stdin.write(bytes(rgba))

    def finish(self) -> None:
        """Close the pipe and let ffmpeg finish the file."""
        self.writer.finish()

    def abort(self) -> None:
        """Stop ffmpeg without finishing the file."""
        proc = getattr(self.writer, "_proc", None)
        if proc is not None:  # stop ffmpeg without finishing the file
            proc.kill()
            proc.wait()


def render_frames(scene, idx: np.ndarray, add, progress: Progress | None = None) -> None:
    """Draw the static parts once, then per frame only the moving artists over a copy of them (Agg
    blitting) and hand the RGBA buffer to ``add``."""
    fig = scene.fig
    canvas = fig.canvas
    for artist in scene.dynamic:
        artist.set_animated(True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    for n, i in enumerate(idx):
        canvas.restore_region(background)
        scene.update(int(i))
        for artist in scene.dynamic:
            if hasattr(artist, "do_3d_projection"):
                artist.do_3d_projection()
            fig.draw_artist(artist)
        add(canvas.buffer_rgba())
        if progress is not None:
            progress(n + 1, len(idx))


def write_movie(scene, idx: np.ndarray, out_path: Path, suffix: str, fps: float, progress, colors=()) -> None:
    """Render the frames ``idx`` (F,) of ``scene`` into ``out_path`` (.gif or .mp4) atomically
    (``saving.atomic_output``: nothing is left behind on error or Ctrl-C); a GIF's palette ramps to
    ``scene.colors``, else to ``colors``."""
    with atomic_output(out_path) as tmp:
        if suffix == ".mp4":
            sink = FfmpegSink(tmp, scene.fig, fps)
        else:
            w, h = (int(round(v)) for v in scene.fig.bbox.size)
            colors = getattr(scene, "colors", colors)
            sink = GifSink(tmp, (w, h), fps, colors=colors)
        try:
            render_frames(scene, idx, sink.add, progress)
            sink.finish()
        except BaseException:
            sink.abort()
            raise
