"""Ray geometry on a hand-built scene, with hand-computed alphas (Eq. 3 on top)."""

import math

import pytest
from conftest import place, tiny_dict

from cmdp_pymunk import parallel_env
from cmdp_pymunk.cases.load import case_from_dict
from cmdp_pymunk.observe import observe_crew
from cmdp_pymunk.streams import RandomStreams
from cmdp_pymunk.world import COMPONENT, CREW, STORAGE, TASK_AREA, WALL

SCALE = 1 / 6  # type ids are scaled by 1/6


def scene():
    """One crew at the origin facing +x; component B at x 4..6; 3 frontal rays (-60, 0, 60 deg)
    of 10 m and 4 surrounding rays (0, 90, 180, 270 deg) of 3 m."""
    data = tiny_dict()
    data["simulation"].update(frontal_rays=3, surrounding_rays=4, field_of_view_deg=120.0,
                              sight_distance_m=10.0, surrounding_distance_m=3.0)
    data["components"] = [
        {"id": "B", "x_m": 5.0, "y_m": 0.0, "width_m": 2.0, "height_m": 2.0},
        {"id": "A", "x_m": -8.0, "y_m": 4.0, "width_m": 1.0, "height_m": 1.0},
        {"id": "C", "x_m": -8.0, "y_m": -2.0, "width_m": 1.0, "height_m": 1.0},
    ]
    env = parallel_env(case=case_from_dict(data), seed=0)
    env.reset(seed=0)
    for i, (x, y) in enumerate([(0.0, 0.0), (-9.0, 5.0), (0.0, -2.5), (-9.0, -5.0)]):
        place(env, i, x, y)
    return env


def ray(obs, j):
    return tuple(float(v) for v in obs[4 * j: 4 * j + 4])


def test_frontal_and_surrounding_rays_hit_what_they_should():
    env = scene()
    crew = env.engine.site.crews[0]
    crew.scope, crew.values = {0: -1}, {0: 0.7}  # component B is a target worth 0.7
    obs = observe_crew(env.engine.world, env.rays, crew)
    assert obs.shape == (4 * 7 + 3,)
    # frontal ray at 0 deg: B's face at x = 4 of 10 m -> 0.4; B is in scope -> V = 0.7
    assert ray(obs, 1) == pytest.approx((0.4, 0.0, COMPONENT * SCALE, 0.7), abs=1e-6)
    # frontal ray at +60 deg reaches y = 10 * sin 60 = 8.66 > 6 - 0.1: the top wall (radius
    # 0.1) at y = 5.9 -> length 5.9 / sin 60 = 6.8127 of 10
    assert ray(obs, 2) == pytest.approx((5.9 / math.sin(math.pi / 3) / 10, 1 / 3,
                                         WALL * SCALE, 0.0), abs=1e-5)
    # surrounding ray at 270 deg: crew M-1 (r = sqrt(1/pi) = 0.5642) at y = -2.5 -> its edge
    # at 2.5 - 0.5642 = 1.9358 of 3 m
    r = math.sqrt(1.0 / math.pi)
    assert ray(obs, 6) == pytest.approx(((2.5 - r) / 3, -0.5, CREW * SCALE, 0.0), abs=1e-5)
    # surrounding ray at 0 deg: 3 m, B starts at 4 m -> nothing (length 1, type 0)
    assert ray(obs, 3) == pytest.approx((1.0, 0.0, 0.0, 0.0))
    # the crew never sees itself: no ray reads length 0
    assert all(obs[4 * j] > 0 for j in range(7))


def test_out_of_scope_target_reads_zero_and_heading_rotates_rays():
    env = scene()
    crew = env.engine.site.crews[0]
    crew.scope, crew.values = {}, {}
    place(env, 0, 0.0, 0.0, angle=math.pi / 2)  # facing +y
    obs = observe_crew(env.engine.world, env.rays, crew)
    # frontal ray at 0 deg now points up: the top wall at 5.9 m -> 0.59
    assert ray(obs, 1) == pytest.approx((0.59, 0.0, WALL * SCALE, 0.0), abs=1e-6)
    # the surrounding ray at -90 deg (index 3 + 3) now points along +x: nothing within 3 m
    assert ray(obs, 6)[2] == 0.0
    # facing +y, the frontal ray at -60 deg points 30 deg above +x: it passes over B (y = 2.31
    # at x = 4) and meets the storage's lower edge y = 3.5 at 3.5 / sin 30 = 7 m -> 0.7;
    # the storage is not in scope -> V = 0
    assert ray(obs, 0) == pytest.approx((0.7, -1 / 3, STORAGE * SCALE, 0.0), abs=1e-6)


def test_frontal_rays_look_through_task_areas_surrounding_rays_stop_there():
    env = scene()
    crew = env.engine.site.crews[0]
    crew.scope, crew.values = {0: -1}, {0: 0.9}
    env.engine.world.add_task_area(99, (2.0, -1.5, 3.5, 1.5))  # an area between the crew and B
    env.engine.world.add_task_area(98, (-4.0, -1.0, -1.5, 1.0))  # an area behind the crew
    obs = observe_crew(env.engine.world, env.rays, crew)
    assert ray(obs, 1) == pytest.approx((0.4, 0.0, COMPONENT * SCALE, 0.9), abs=1e-6)
    # surrounding 0 deg: the area at x = 2 of 3 m; 180 deg: the area's edge at x = -1.5 -> 0.5
    assert ray(obs, 3) == pytest.approx((2 / 3, 0.0, TASK_AREA * SCALE, 0.0), abs=1e-6)
    assert ray(obs, 5) == pytest.approx((0.5, 1.0, TASK_AREA * SCALE, 0.0), abs=1e-6)


def test_fast_rays_answer_like_the_public_api():
    from cmdp_pymunk.world import RayCaster

    env = scene()
    env.engine.world.add_task_area(99, (2.0, -1.5, 3.5, 1.5))
    fast, public = env.engine.world.rays, RayCaster(env.engine.world.space, public=True)
    assert fast.fast and not public.fast
    for crew in env.engine.site.crews:
        x, y = env.engine.positions[crew.index]
        for ex, ey, frontal in env.rays.endpoints(x, y, 0.3 * crew.index):
            flt = env.engine.world.frontal_filters[crew.index] if frontal else \
                env.engine.world.surrounding_filters[crew.index]
            a, b = fast.cast((x, y), (ex, ey), flt), public.cast((x, y), (ex, ey), flt)
            assert (a is None and b is None) or (a[1:] == b[1:] and a[0] == pytest.approx(b[0]))
    env.engine.world.remove_task_area(99)
    assert all(k != 99 for k in env.engine.world.area_shapes)


def test_target_memory_remembers_the_last_sighting_in_the_crew_frame():
    """Beyond the paper: the latest sighting of a target in scope, hand-computed."""
    from cmdp_pymunk.observe import MEMORY_FEATURES, RayModel, remembered_target

    env = scene()
    crew = env.engine.site.crews[0]
    crew.scope, crew.values = {0: -1}, {0: 0.7}
    rays = RayModel(3, 4, 120.0, 10.0, 3.0, memory=True, memory_age_s=300.0)
    assert rays.size == 4 * 7 + 3 + MEMORY_FEATURES
    obs = observe_crew(env.engine.world, rays, crew, now_s=100.0)
    # the 0 deg frontal ray hits B's face at (4, 0): the sighting of target 0, stamped 100 s
    assert crew.sightings[0] == pytest.approx((4.0, 0.0, 100.0), abs=1e-6)
    assert list(obs[-MEMORY_FEATURES:]) == [0.0] * MEMORY_FEATURES  # filled by the env
    # 160 s later the crew stands at (1, 3) facing +y: the point is 3 m behind (forward -3/10)
    # and 3 m to its right (left -3/10); age 60 / 300
    assert remembered_target(rays, crew, 1.0, 3.0, math.pi / 2, 160.0) == pytest.approx(
        (1.0, -0.3, -0.3, 0.2), abs=1e-6)
    # ages cap at 1; a target outside the scope is not offered
    assert remembered_target(rays, crew, 1.0, 3.0, 0.0, 1000.0)[3] == 1.0
    crew.scope = {1: -1}
    assert remembered_target(rays, crew, 1.0, 3.0, 0.0, 160.0) == (0.0, 0.0, 0.0, 0.0)
    # a look without the target in view keeps the old sighting; of two, the latest is offered
    observe_crew(env.engine.world, rays, crew, now_s=200.0)
    assert crew.sightings[0][2] == 100.0
    crew.sightings[1] = (1.0, 5.0, 150.0)
    crew.scope = {0: -1, 1: -1}
    assert remembered_target(rays, crew, 1.0, 3.0, 0.0, 160.0) == pytest.approx(
        (1.0, 0.0, 0.2, 10 / 300), abs=1e-6)


def test_a_crew_in_a_storage_sees_out_of_it_with_its_frontal_rays():
    env = scene()
    crew = env.engine.site.crews[0]
    crew.scope, crew.values = {0: -1}, {0: 0.7}
    # storage S spans x 4.5..7.5, y 3.5..5.5; the crew stands in it at (5.5, 4.5) facing -y
    place(env, 0, 5.5, 4.5, angle=-math.pi / 2)
    obs = observe_crew(env.engine.world, env.rays, crew)
    # the 0 deg frontal ray leaves S at y = 3.5 (1 m) and meets B's top face y = 1 at 3.5 m
    assert ray(obs, 1) == pytest.approx((0.35, 0.0, COMPONENT * SCALE, 0.7), abs=1e-5)
    # surrounding rays still report the storage around the crew, at length 0
    assert ray(obs, 3)[0] == 0.0 and ray(obs, 3)[2] == pytest.approx(STORAGE * SCALE)


def test_a_crew_remembers_where_it_paused_its_task():

    from cmdp_pymunk import decide

    env = scene()
    crew = env.engine.site.crews[0]
    crew.task = 3  # M-C, on component C (target 2)
    env.engine.site.time_s = 42.0
    engine = env.engine
    ctx = decide.Context(engine.site, engine.world, engine.positions, RandomStreams(0), env.log)
    decide.pause_task(crew, ctx)
    assert crew.sightings[env.engine.site.tasks[3].component] == (0.0, 0.0, 42.0)


def test_env_observation_carries_memory_only_when_the_case_asks():
    data = tiny_dict()
    data["simulation"]["target_memory"] = True
    env = parallel_env(case=case_from_dict(data), seed=0)
    obs, _ = env.reset(seed=0)
    plain = parallel_env(case=case_from_dict(tiny_dict()), seed=0)
    size = plain.observation_space(plain.possible_agents[0]).shape[0]
    assert env.observation_space(env.possible_agents[0]).shape == (size + 4,)
    assert all(o.shape == (size + 4,) for o in obs.values())
