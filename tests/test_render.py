"""The rendered frame (media/render.py)."""

from __future__ import annotations

import math
import os

os.environ["SDL_VIDEODRIVER"] = "dummy"
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from conftest import distinct_colours  # noqa: E402

from cmdp_pymunk import parallel_env  # noqa: E402
from cmdp_pymunk.state import CrewStatus, Pool  # noqa: E402
from media import render  # noqa: E402


@pytest.fixture
def rendered_env(tiny_case):
    """The tiny case (a non-square 20 x 12 m plane) a few steps in, every crew driving."""
    env = parallel_env(case=tiny_case, seed=0, render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(4):
        env.step({a: (3, 1, 1) for a in env.agents})
    return env


def _has_colour(frame, col: int, row: int, half: int, colour) -> bool:
    window = frame[max(row - half, 0):row + half + 1, max(col - half, 0):col + half + 1]
    return bool(np.all(window == np.array(colour, dtype=np.uint8), axis=-1).any())


def _lone_crew(env) -> int:
    """A crew whose mirror image across y = 0 is far from every crew of its type, so that a
    frame drawn with y not flipped would put its colour where no such crew is."""
    site = env.engine.site
    for crew in site.crews:
        x, y = env.engine.world.bodies[crew.index].position
        if abs(y) < 2.0:
            continue
        if all(math.dist((x, -y), env.engine.world.bodies[o.index].position) > 2.0
               for o in site.crews if o.type == crew.type):
            return crew.index
    raise AssertionError("the tiny case has no crew away from the x axis")


def test_frame_shape_dtype_and_not_uniform(rendered_env):
    frame = rendered_env.render()
    width, height = render.Viewport.of(rendered_env.case.plane).size
    assert frame.shape == (height, width, 3)
    assert frame.dtype == np.uint8
    assert frame.flags.writeable and frame.flags.c_contiguous
    assert distinct_colours(frame) > 10


def test_default_scale_is_about_900_px_wide(rendered_env):
    assert 880 <= rendered_env.render().shape[1] <= 920


@pytest.mark.parametrize("px_per_m", [None, 10.0])
def test_crew_colour_is_drawn_where_the_crew_is(rendered_env, px_per_m):
    env = rendered_env
    i = _lone_crew(env)
    frame = render.draw_frame(env.engine, px_per_m=px_per_m)
    x, y = env.engine.world.bodies[i].position
    scale = render.Viewport.of(env.case.plane, px_per_m).px_per_m
    half = max(1, int(env.engine.site.crews[i].spec.radius_m * scale * 0.6))  # inside the disc
    colour = render.crew_colour(env.engine, i)
    col, row = render.world_to_pixel(env.engine, x, y, px_per_m)
    assert _has_colour(frame, col, row, half, colour)
    # y is flipped: nothing of that colour at the crew's mirror image across the x axis
    mcol, mrow = render.world_to_pixel(env.engine, x, -y, px_per_m)
    assert not _has_colour(frame, mcol, mrow, half, colour)


def test_world_to_pixel_flips_y_and_centres_the_origin(rendered_env):
    env = rendered_env
    vp = render.Viewport.of(env.case.plane, 10.0)
    cx, cy = vp.to_px(0.0, 0.0)
    # the tiny plane is 20 x 12 m: its top-left corner (-10, 6) is 100 px left, 60 px up
    assert vp.to_px(-10.0, 6.0) == (cx - 100, cy - 60)
    assert vp.to_px(10.0, -6.0) == (cx + 100, cy + 60)
    assert render.world_to_pixel(env.engine, 1.0, 2.0, 10.0) == (cx + 10, cy - 20)


def test_left_crews_are_not_drawn(rendered_env):
    env = rendered_env
    i = _lone_crew(env)
    env.engine.site.crews[i].status = CrewStatus.LEFT  # hand-made state: the crew has gone
    frame = env.render()
    col, row = render.world_to_pixel(env.engine, *env.engine.world.bodies[i].position)
    assert not _has_colour(frame, col, row, 3, render.crew_colour(env.engine, i))


def test_component_colours_follow_the_task_pools(tiny_env):
    site = tiny_env.engine.site
    ids = {c.id: c.index for c in site.components}
    # conftest: A and B start with a queued task, C's task waits for K-A
    assert render.component_colour(site, ids["A"]) == render.COMPONENT_EXECUTABLE
    assert render.component_colour(site, ids["C"]) == render.COMPONENT_WAITING
    for t in site.components[ids["B"]].tasks:
        site.tasks[t].pool = Pool.END
    assert render.component_colour(site, ids["B"]) == render.COMPONENT_DONE
    site.tasks[site.components[ids["A"]].tasks[0]].pool = Pool.ON
    assert render.component_colour(site, ids["A"]) == render.COMPONENT_PERFORMING


def test_rays_are_drawn_only_on_request(rendered_env):
    plain = render.draw_frame(rendered_env.engine)
    rays = rendered_env.rays
    assert np.array_equal(plain, render.draw_frame(rendered_env.engine, rays, show_rays=False))
    assert not np.array_equal(plain, render.draw_frame(rendered_env.engine, rays, show_rays=True))


def test_clock_format():
    assert render.format_clock(0) == "0:00:00"
    assert render.format_clock(3725.9) == "1:02:05"  # 1 h, 2 min, 5 s


def test_render_before_reset_draws_the_empty_plane(tiny_case):
    env = parallel_env(case=tiny_case, render_mode="rgb_array")
    width, height = render.Viewport.of(tiny_case.plane).size
    assert env.render().shape == (height, width, 3)


def test_render_without_render_mode_returns_none(tiny_env):
    assert tiny_env.render() is None


def test_crew_labels_never_overlap_when_crews_crowd(tiny_case):
    """Four crews on one spot (as at t = 0 by the outlet): each label block lands clear of
    the discs and of the labels placed before it."""
    import pygame

    centre, radius, size = (100, 100), 8, (40, 24)
    taken = [pygame.Rect(92, 92, 16, 16)]  # the disc
    for _ in range(4):
        rect, _far = render.label_place(size, centre, radius, taken)
        assert rect.collidelist(taken) == -1
        taken.append(rect)
    # the first goes right above the disc (no line back), the fifth needs a second ring
    first, far = render.label_place(size, centre, radius, taken[:1])
    assert not far and first.bottom == centre[1] - radius - 1
    assert render.label_place(size, centre, radius, taken)[1]


def test_the_legend_shows_every_state_colour_and_crew_type(rendered_env):
    frame = rendered_env.render()
    vp = render.Viewport.of(rendered_env.case.plane)
    legend = frame[vp.size[1] - render.LEGEND_PX:]
    colours = {tuple(c) for c in legend.reshape(-1, 3)}
    for colour in (render.COMPONENT_WAITING, render.COMPONENT_EXECUTABLE,
                   render.COMPONENT_PERFORMING, render.COMPONENT_DONE, render.DISRUPTED):
        assert colour in colours, colour
    for i, _ in enumerate(rendered_env.case.crew_types):
        assert render.CREW_PALETTE[i] in colours
