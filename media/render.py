"""One frame of the site as an RGB array, drawn with pygame off screen (``CMDPEnv.render``).

What a frame shows, back to front: the work plane and its walls; active task areas as
translucent orange rectangles; storages with a bar for their stock; components coloured by the
state of their tasks (grey: waiting for predecessors or blocked, blue: an executable task,
red: a task being performed, green: every task ended); the outlet; the tower crane with its
queue length; the crews (a disc of the crew's occupation area in its crew type's colour, a
tick for its heading, its id and its status beside it, placed where no other crew's label is:
above, below, right or left of the disc, or further off with a thin line back to it) with a
thin line to the target it values most while it moves; a clock line above the plane (it
says "event floor" for a frame of the event floor, whose crews jump along their walks from
event to event: docs/event-floor.md); and below the plane a legend of the colours
(component states, task areas, storages, crane, outlet, disruptions, and each crew type's
colour with its name).

With disruptions (docs/disruptions.md): the header names what is disrupted (weather stop,
crane down, late deliveries, crews away) in magenta; a broken-down crane is crossed out; a
storage whose delivery is late gets a thick magenta edge; an absent crew is not drawn (it is
off the plane).

Coordinates: the plane's origin is its centre and y points up (``cmdp_pymunk.cases.load``); on
screen y points down, so ``world_to_pixel`` flips it. ``Viewport`` is the one transform, and
tests use it to find where a crew is drawn.

The simulation core never imports this module except lazily in ``render()``; everything here
only reads the engine's state (``draw_frame(engine, rays)``).
"""

from __future__ import annotations

import math
import os
import weakref
from dataclasses import dataclass

import numpy as np

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame  # noqa: E402  (the environment variables above must be set first)

from cmdp_pymunk.geometry import Outline  # noqa: E402
from cmdp_pymunk.observe import ray_model  # noqa: E402
from cmdp_pymunk.precedence import component_attributes  # noqa: E402
from cmdp_pymunk.state import CrewStatus, Pool  # noqa: E402

TARGET_WIDTH_PX = 900  # the default scale fits the plane into about this width
MARGIN_PX = 18
HEADER_PX = 24  # the clock line above the plane
LEGEND_ROW_PX = 17
LEGEND_PX = 3 * LEGEND_ROW_PX + 6  # three rows below the plane: states, places, crew types

Colour = tuple[int, int, int]
BACKGROUND: Colour = (250, 250, 247)
PLANE: Colour = (236, 236, 230)
WALL: Colour = (40, 40, 40)
GRID: Colour = (224, 224, 218)
TEXT: Colour = (25, 25, 25)
COMPONENT_WAITING: Colour = (170, 170, 170)
COMPONENT_EXECUTABLE: Colour = (66, 120, 220)
COMPONENT_PERFORMING: Colour = (215, 50, 45)
COMPONENT_DONE: Colour = (70, 170, 85)
TASK_AREA = (255, 150, 30, 70)  # RGBA: translucent
STORAGE_EDGE: Colour = (120, 95, 60)
DISRUPTED: Colour = (200, 30, 120)  # what a disruption strikes (docs/disruptions.md)
STORAGE_FILL: Colour = (205, 170, 110)
OUTLET: Colour = (20, 130, 60)
CRANE: Colour = (235, 180, 0)
RAY: Colour = (200, 205, 215)
LABEL_BOX: Colour = (255, 255, 255)
# Crew type colours, in the case's crew-type order; none of them is a component state colour.
CREW_PALETTE: tuple[Colour, ...] = (
    (140, 40, 170),   # purple
    (0, 150, 150),    # teal
    (225, 0, 140),    # magenta
    (140, 85, 30),    # brown
    (110, 130, 0),    # olive
    (20, 40, 110),    # navy
    (240, 120, 160),  # pink
    (90, 90, 90),     # dark grey
)


@dataclass(frozen=True)
class Viewport:
    """The map from plane metres (origin at the centre, y up) to image pixels (y down)."""

    width_m: float
    height_m: float
    px_per_m: float

    @classmethod
    def of(cls, plane, px_per_m: float | None = None) -> Viewport:
        """The plane's viewport; ``px_per_m=None`` fits it into ``TARGET_WIDTH_PX``."""
        if px_per_m is None:
            px_per_m = (TARGET_WIDTH_PX - 2 * MARGIN_PX) / plane.width_m
        if px_per_m <= 0:
            raise ValueError(f"px_per_m must be positive, not {px_per_m!r}")
        return cls(plane.width_m, plane.height_m, float(px_per_m))

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of the image in pixels."""
        return (round(self.width_m * self.px_per_m) + 2 * MARGIN_PX,
                round(self.height_m * self.px_per_m) + 2 * MARGIN_PX + HEADER_PX + LEGEND_PX)

    def to_px(self, x: float, y: float) -> tuple[int, int]:
        """Pixel (column, row) of the plane point (x, y) in metres."""
        s = self.px_per_m
        return (MARGIN_PX + round((x + self.width_m / 2) * s),
                HEADER_PX + MARGIN_PX + round((self.height_m / 2 - y) * s))

    def rect_px(self, rect) -> pygame.Rect:
        """The screen rectangle of a plane rectangle (x0, y0, x1, y1) in metres."""
        left, top = self.to_px(rect[0], rect[3])
        right, bottom = self.to_px(rect[2], rect[1])
        return pygame.Rect(left, top, max(1, right - left), max(1, bottom - top))


def world_to_pixel(engine, x: float, y: float, px_per_m: float | None = None) -> tuple[int, int]:
    """Where ``draw_frame(engine, px_per_m=px_per_m)`` draws the plane point (x, y): (column,
    row)."""
    return Viewport.of(engine.case.plane, px_per_m).to_px(x, y)


def crew_colour(engine, crew: int) -> Colour:
    """The colour of the crew's disc: one per crew type, in the case's crew-type order."""
    types = list(engine.case.crew_types)
    return CREW_PALETTE[types.index(engine.site.crews[crew].type) % len(CREW_PALETTE)]


def component_colour(site, component: int) -> Colour:
    """Grey waiting, blue with an executable task, red being performed, green all ended."""
    executable, performing = component_attributes(site, component)
    if performing is not None:
        return COMPONENT_PERFORMING
    if executable and any(site.executable(site.tasks[t])
                          for t in site.components[component].tasks):
        return COMPONENT_EXECUTABLE
    if all(site.tasks[t].pool == Pool.END for t in site.components[component].tasks):
        return COMPONENT_DONE
    return COMPONENT_WAITING


def _short(quantity: float) -> str:
    """A stock for a label: one decimal at most, and no float residue such as 2.2e-13."""
    return f"{round(quantity, 1) + 0.0:g}"


def format_clock(time_s: float) -> str:
    """Simulated time as h:mm:ss."""
    s = int(time_s)
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


class _Fonts:
    """pygame's fonts, made once: a font per frame would dominate the cost of a GIF."""

    _made = False

    @classmethod
    def get(cls) -> _Fonts:
        if not cls._made:
            pygame.font.init()
            cls.small = pygame.font.Font(None, 14)
            cls.label = pygame.font.Font(None, 16)
            cls.header = pygame.font.Font(None, 22)
            cls._made = True
        return cls


class _Renderer:
    """Per-env caches: the static background and rendered text (labels repeat every frame)."""

    MAX_TEXTS = 1024

    def __init__(self, case, viewport: Viewport):
        self.case = case
        self.viewport = viewport
        self.fonts = _Fonts.get()
        self.texts: dict = {}
        self.surface = pygame.Surface(viewport.size)
        half_w, half_h = case.plane.half_extents
        self.plane_rect = viewport.rect_px((-half_w, -half_h, half_w, half_h))
        self.background = self._draw_background()

    def text(self, font, string: str, colour: Colour = TEXT,
             background: Colour | None = None) -> pygame.Surface:
        key = (id(font), string, colour, background)
        surf = self.texts.get(key)
        if surf is None:
            if len(self.texts) >= self.MAX_TEXTS:  # e.g. stock numbers over a long episode
                self.texts.clear()
            surf = self.texts[key] = font.render(string, True, colour, background)
        return surf

    def blit_centred(self, surf: pygame.Surface, centre: tuple[int, int]) -> None:
        self.surface.blit(surf, surf.get_rect(center=centre))

    def _draw_background(self) -> pygame.Surface:
        """What never changes: plane, grid every 5 m, walls, outlet."""
        vp, plane = self.viewport, self.case.plane
        bg = pygame.Surface(vp.size)
        bg.fill(BACKGROUND)
        half_w, half_h = plane.half_extents
        plane_rect = self.plane_rect
        bg.fill(PLANE, plane_rect)
        for k in range(-int(half_w // 5), int(half_w // 5) + 1):
            x, _ = vp.to_px(5.0 * k, 0.0)
            pygame.draw.line(bg, GRID, (x, plane_rect.top), (x, plane_rect.bottom - 1))
        for k in range(-int(half_h // 5), int(half_h // 5) + 1):
            _, y = vp.to_px(0.0, 5.0 * k)
            pygame.draw.line(bg, GRID, (plane_rect.left, y), (plane_rect.right - 1, y))
        pygame.draw.rect(bg, WALL, plane_rect, width=3)
        centre = vp.to_px(plane.outlet_x_m, plane.outlet_y_m)
        radius = max(2, round(plane.outlet_radius_m * vp.px_per_m))
        pygame.draw.circle(bg, (205, 235, 210), centre, radius)
        pygame.draw.circle(bg, OUTLET, centre, radius, width=2)
        label = self.fonts.small.render("outlet", True, OUTLET)
        bg.blit(label, label.get_rect(midtop=(centre[0], centre[1] + radius + 2)))
        self._draw_legend(bg)
        return bg

    def _draw_legend(self, bg: pygame.Surface) -> None:
        """Three rows under the plane: what each colour of a frame means."""
        font = self.fonts.label
        types = list(self.case.crew_types.items())
        rows = [
            [("rect", COMPONENT_WAITING, "component: waiting or blocked"),
             ("rect", COMPONENT_EXECUTABLE, "executable task"),
             ("rect", COMPONENT_PERFORMING, "task being performed"),
             ("rect", COMPONENT_DONE, "all its tasks ended")],
            [("area", TASK_AREA, "active task area"),
             ("storage", STORAGE_FILL, "storage (stock/capacity)"),
             ("crane", CRANE, "tower crane (queue)"), ("outlet", OUTLET, "outlet"),
             ("rect", DISRUPTED, "disrupted")],
            [("disc", CREW_PALETTE[i % len(CREW_PALETTE)], f"{key} {ct.name.lower()}")
             for i, (key, ct) in enumerate(types)],
        ]
        top = self.plane_rect.bottom + MARGIN_PX // 2
        for r, row in enumerate(rows):
            x, y = MARGIN_PX, top + r * LEGEND_ROW_PX + LEGEND_ROW_PX // 2
            for kind, colour, text in row:
                swatch = pygame.Rect(x, y - 6, 12, 12)
                if kind == "disc":
                    pygame.draw.circle(bg, colour, swatch.center, 6)
                    pygame.draw.circle(bg, WALL, swatch.center, 6, width=1)
                elif kind == "crane":
                    points = [(swatch.centerx, swatch.top), swatch.bottomleft, swatch.bottomright]
                    pygame.draw.polygon(bg, colour, points)
                    pygame.draw.polygon(bg, WALL, points, width=1)
                elif kind == "outlet":
                    pygame.draw.circle(bg, OUTLET, swatch.center, 6, width=2)
                elif kind == "area":
                    bg.fill((255, 212, 160), swatch)  # TASK_AREA over the plane
                    pygame.draw.rect(bg, (235, 130, 20), swatch, width=1)
                elif kind == "storage":
                    bg.fill((245, 238, 222), swatch)
                    bg.fill(colour, swatch.inflate(0, -6).move(0, 3))
                    pygame.draw.rect(bg, STORAGE_EDGE, swatch, width=2)
                else:
                    bg.fill(colour, swatch)
                    pygame.draw.rect(bg, WALL, swatch, width=1)
                label = font.render(text, True, TEXT)
                bg.blit(label, label.get_rect(midleft=(x + 16, y)))
                x += 16 + label.get_width() + 14

    def draw(self, engine, rays, show_rays: bool) -> np.ndarray:
        site, vp, fonts = engine.site, self.viewport, self.fonts
        surface = self.surface
        surface.blit(self.background, (0, 0))
        if site is None:  # before reset(): the empty plane
            return _to_array(surface)

        for t in site.active_areas:
            area = site.tasks[t].area
            r = vp.rect_px(area)
            patch = pygame.Surface(r.size, pygame.SRCALPHA)
            if isinstance(area, Outline):  # a polygon component's area: its polygon only
                points = [vp.to_px(x, y) for x, y in area.points]
                pygame.draw.polygon(patch, TASK_AREA, [(px - r.left, py - r.top)
                                                       for px, py in points])
                surface.blit(patch, r.topleft)
                pygame.draw.polygon(surface, (235, 130, 20), points, width=1)
                continue
            patch.fill(TASK_AREA)
            surface.blit(patch, r.topleft)
            pygame.draw.rect(surface, (235, 130, 20), r, width=1)

        if show_rays:
            self._draw_rays(engine, rays)

        for st in site.storages:
            r = vp.rect_px(st.rect)
            fill = min(1.0, st.stock / st.capacity) if st.capacity > 0 else 0.0
            surface.fill((245, 238, 222), r)
            bar = pygame.Rect(r.left, r.bottom - round(r.height * fill), r.width,
                              round(r.height * fill))
            if bar.height > 0:
                surface.fill(STORAGE_FILL, bar)
            late = site.disrupted is not None and st.index in site.disrupted.late
            pygame.draw.rect(surface, DISRUPTED if late else STORAGE_EDGE, r,
                             width=4 if late else 2)
            self.blit_centred(self.text(fonts.label, st.material + (" (late)" if late else "")),
                              (r.centerx, r.centery - 7))
            self.blit_centred(self.text(fonts.small, f"{_short(st.stock)}/{_short(st.capacity)}"),
                              (r.centerx, r.centery + 7))

        for comp in site.components:
            r = vp.rect_px(comp.rect)
            colour = component_colour(site, comp.index)
            if isinstance(comp.rect, Outline):  # a polygon component: drawn as its outline
                points = [vp.to_px(x, y) for x, y in comp.rect.points]
                pygame.draw.polygon(surface, colour, points)
                pygame.draw.polygon(surface, WALL, points, width=1)
            else:
                surface.fill(colour, r)
                pygame.draw.rect(surface, WALL, r, width=1)
            ink = TEXT if colour == COMPONENT_WAITING else (255, 255, 255)
            self.blit_centred(self.text(fonts.small, comp.id, ink), r.center)

        crane = engine.case.crane
        cx, cy = vp.to_px(crane.x_m, crane.y_m)
        pygame.draw.polygon(surface, CRANE, [(cx, cy - 9), (cx - 8, cy + 6), (cx + 8, cy + 6)])
        pygame.draw.polygon(surface, WALL, [(cx, cy - 9), (cx - 8, cy + 6), (cx + 8, cy + 6)],
                            width=1)
        queue = len(site.crane.queue) + (1 if site.crane.current is not None else 0)
        down = site.disrupted is not None and site.disrupted.crane_down
        if down:
            pygame.draw.line(surface, DISRUPTED, (cx - 9, cy - 10), (cx + 9, cy + 8), 3)
            pygame.draw.line(surface, DISRUPTED, (cx - 9, cy + 8), (cx + 9, cy - 10), 3)
        label = self.text(fonts.label, f"crane q={queue}" + (" DOWN" if down else ""),
                          DISRUPTED if down else TEXT)
        surface.blit(label, label.get_rect(midleft=(cx + 11, cy)))

        self._draw_crews(engine)

        header = (f"t {format_clock(site.time_s)}   tasks {site.tasks_ended}/{len(site.tasks)}"
                  f"   stage {engine.stage}   {engine.case.case.name}"
                  # the event floor's crews jump along their walks: say whose frame this is
                  + ("   event floor" if engine.motion.name == "event" else ""))
        disrupted = disruption_text(site)
        if disrupted:
            header += "   " + disrupted
        surface.blit(fonts.header.render(header, True, DISRUPTED if disrupted else TEXT),
                     (MARGIN_PX, 6))
        return _to_array(surface)

    def _draw_rays(self, engine, rays) -> None:
        """Every moving crew's rays to their full length (not to what they hit), faintly."""
        vp, surface = self.viewport, self.surface
        surface.set_clip(self.plane_rect)  # long frontal rays end beyond the walls
        for crew in engine.site.crews:
            if crew.moving:
                x, y, heading = engine.pose(crew.index)
                start = vp.to_px(x, y)
                for ex, ey, _frontal in rays.endpoints(x, y, heading):
                    pygame.draw.line(surface, RAY, start, vp.to_px(ex, ey))
        surface.set_clip(None)

    def _draw_crews(self, engine) -> None:
        site, vp, fonts = engine.site, self.viewport, self.fonts
        surface = self.surface
        # an absent crew is off the plane (its body too): not drawn, named in the header
        crews = [c for c in site.crews if c.status != CrewStatus.LEFT and not c.absent]
        positions = {}
        for crew in crews:
            positions[crew.index] = engine.pose(crew.index)
        surface.set_clip(self.plane_rect)
        for crew in crews:  # target lines under every disc
            if crew.moving and crew.values:
                x, y, _ = positions[crew.index]
                target = max(crew.values, key=crew.values.get)
                tx, ty = site.target_xy[target]
                pygame.draw.line(surface, crew_colour(engine, crew.index), vp.to_px(x, y),
                                 vp.to_px(tx, ty), 1)
        surface.set_clip(None)
        discs = []
        for crew in crews:
            x, y, angle = positions[crew.index]
            centre = vp.to_px(x, y)
            radius = max(3, round(crew.spec.radius_m * vp.px_per_m))
            colour = crew_colour(engine, crew.index)
            pygame.draw.circle(surface, colour, centre, radius)
            pygame.draw.circle(surface, WALL, centre, radius, width=1)
            # the heading tick: screen y is flipped, so the screen angle is -angle
            tip = (centre[0] + round(radius * math.cos(angle)),
                   centre[1] - round(radius * math.sin(angle)))
            pygame.draw.line(surface, (255, 255, 255), centre, tip, 3)
            discs.append((crew, centre, radius, colour))
        # labels on a pale box (they often lie over components), placed clear of each other
        placed = [pygame.Rect(c[0] - r, c[1] - r, 2 * r, 2 * r) for _, c, r, _ in discs]
        for crew, centre, radius, colour in discs:
            label = self.text(fonts.label, crew.id, colour, LABEL_BOX)
            status = self.text(fonts.small, crew.status.name.lower(), TEXT, LABEL_BOX)
            block = pygame.Surface((max(label.get_width(), status.get_width()),
                                    label.get_height() + status.get_height()))
            block.fill(LABEL_BOX)
            block.blit(label, label.get_rect(midtop=(block.get_width() // 2, 0)))
            block.blit(status, status.get_rect(midtop=(block.get_width() // 2,
                                                       label.get_height())))
            rect, far = label_place(block.get_size(), centre, radius, placed)
            if far:
                pygame.draw.line(surface, colour, centre, rect.center, 1)
            surface.blit(block, rect)
            placed.append(rect)


def label_place(size: tuple[int, int], centre: tuple[int, int], radius: int,
                taken: list[pygame.Rect]) -> tuple[pygame.Rect, bool]:
    """Where a crew's label block goes: the first of above, below, right and left of its
    disc, then the same further off (``far``: draw a line back), that overlaps none of
    ``taken``; if every one does, the one that overlaps least."""
    w, h = size
    cx, cy = centre
    best, best_overlap = None, None
    for ring in range(4):
        gap = 1 + ring * (h + 2)
        for rect in (pygame.Rect(cx - w // 2, cy - radius - gap - h, w, h),
                     pygame.Rect(cx - w // 2, cy + radius + gap, w, h),
                     pygame.Rect(cx + radius + gap + 1, cy - h // 2, w, h),
                     pygame.Rect(cx - radius - gap - 1 - w, cy - h // 2, w, h)):
            overlap = sum(rect.clip(t).width * rect.clip(t).height for t in taken)
            if overlap == 0:
                return rect, ring > 0
            if best_overlap is None or overlap < best_overlap:
                best, best_overlap = (rect, ring > 0), overlap
    return best


def disruption_text(site) -> str:
    """What is disrupted now, for the frame's header: "" when nothing is."""
    now = site.disrupted
    if not now:
        return ""
    parts = (["WEATHER STOP"] if now.weather else []) + \
        (["CRANE DOWN"] if now.crane_down else []) + \
        [f"late: {site.storages[s].id}" for s in sorted(now.late)] + \
        [f"away: {site.crews[c].id}" for c in sorted(now.absent)]
    return "   ".join(parts)


def _to_array(surface: pygame.Surface) -> np.ndarray:
    """The surface as a writable (H, W, 3) uint8 array.

    The same pixels as ``surfarray.array3d(surface).transpose(1, 0, 2)`` (which is (W, H, 3)
    before the transpose), but ``image.tobytes`` is already row-major: about 0.8 ms a frame
    instead of 6 ms for array3d plus the copy a contiguous (H, W, 3) array needs.
    """
    w, h = surface.get_size()
    return np.frombuffer(pygame.image.tobytes(surface, "RGB"), np.uint8).reshape(h, w, 3).copy()


_renderers: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def draw_frame(engine, rays=None, px_per_m: float | None = None,
               show_rays: bool = False) -> np.ndarray:
    """The engine's current state as an (H, W, 3) uint8 image.

    Args:
        engine: the floor (``engine.Engine``, only read).
        rays: the crews' ray model (``observe.ray_model(case)``; a ``CMDPEnv``'s ``rays``),
            needed only with ``show_rays``.
        px_per_m: pixels per metre; ``None`` fits the plane into about ``TARGET_WIDTH_PX``
            (16 px/m for the built-in 54 m plane).
        show_rays: also draw the rays of every moving crew, faintly.
    """
    if show_rays and rays is None:
        rays = ray_model(engine.case)
    viewport = Viewport.of(engine.case.plane, px_per_m)
    renderer = _renderers.get(engine)
    if renderer is None or renderer.case is not engine.case or renderer.viewport != viewport:
        renderer = _renderers[engine] = _Renderer(engine.case, viewport)
    return renderer.draw(engine, rays, show_rays)
