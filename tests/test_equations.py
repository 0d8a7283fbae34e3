"""One test per equation, with the numbers worked out by hand in the comments."""

import math

import pytest

from cmdp_pymunk.cases.load import ReachingReward
from cmdp_pymunk.construct import invaded_efficiency
from cmdp_pymunk.evaluate import desired_position_value
from cmdp_pymunk.move import congested_velocity
from cmdp_pymunk.observe import modified_priority
from cmdp_pymunk.reward import reach_reward, reaching_reward
from cmdp_pymunk.world import COMPONENT, CREW, N_KINDS, TASK_AREA, WALL


def test_eq1_congested_velocity():
    # v = max(c * I * v, v_min): (1.2, c=0.7, I=0.5, floor 0.3) -> 0.7*0.5*1.2 = 0.42
    assert congested_velocity(1.2, 0.7, 0.5, 0.3) == pytest.approx(0.42)
    # I = 0.2 -> 0.7*0.2*1.2 = 0.168 < 0.3: the floor
    assert congested_velocity(1.2, 0.7, 0.2, 0.3) == pytest.approx(0.3)
    # no congestion, not carrying: the nominal velocity
    assert congested_velocity(0.5, 1.0, 1.0, 0.1) == pytest.approx(0.5)


def test_eq2_invaded_efficiency():
    # e = max(0, e (1 - n I)): e=0.021, n=2 RC invaders (I=0.24) -> 0.021*(1-0.48) = 0.01092
    assert invaded_efficiency(0.021, 2 * 0.24) == pytest.approx(0.01092)
    # three HIC invaders (I=0.5): 1 - 1.5 < 0 -> 0
    assert invaded_efficiency(0.021, 3 * 0.5) == 0.0
    # mixed invaders sum their indices: JCC 0.4 + GC 0.15 -> 10 * 0.45 = 4.5
    assert invaded_efficiency(10.0, 0.4 + 0.15) == pytest.approx(4.5)


def test_eq3_modified_priority():
    scope, values = {3: 7, 5: -1}, {3: 0.8, 5: 0.25}
    assert modified_priority(3, scope, values) == 0.8  # in scope: its V_Tar
    assert modified_priority(5, scope, values) == 0.25
    assert modified_priority(4, scope, values) == 0.0  # a target outside the scope
    assert modified_priority(-1, scope, values) == 0.0  # not a target (wall, crew, area)


def test_eq4_desired_position_value_on_a_non_square_plane():
    half = (27.0, 18.0)  # a 54 x 36 m plane: x_max = 27, y_max = 18
    # target (13.5, -9) -> (0.5, -0.5); desired (0.5, -0.5) -> V = 1
    assert desired_position_value((0.5, -0.5), (13.5, -9.0), half) == pytest.approx(1.0)
    # desired (-0.5, 0.0): dx = -1.0, dy = 0.5 -> 1 - sqrt(1.25) = -0.1180
    assert desired_position_value((-0.5, 0.0), (13.5, -9.0), half) == \
        pytest.approx(1 - math.sqrt(1.25))
    # x and y swapped must differ: target (9, -13.5) -> (1/3, -0.75); from (0.5,-0.5):
    # dx = 1/6, dy = 0.25 -> 1 - sqrt(1/36 + 1/16) = 0.69954
    assert desired_position_value((0.5, -0.5), (9.0, -13.5), half) == pytest.approx(0.699538, 1e-5)


def test_eq7_reach_reward():
    assert reach_reward(2.0, 0.75) == 1.5  # k * V_Tar
    assert reach_reward(1.0, -0.25) == -0.25  # an Eq. 4 value can be negative


def test_eq6_reaching_reward():
    w = ReachingReward(eta_wall=0.05, eta_component=0.1, eta_crew=0.2, eta_task_area=0.3,
                       priority_scale_k=2.0, time_penalty=0.001)
    eta = [0.0] * N_KINDS
    eta[WALL], eta[COMPONENT], eta[CREW], eta[TASK_AREA] = 0.05, 0.1, 0.2, 0.3
    contacts = [0] * N_KINDS
    contacts[WALL], contacts[CREW], contacts[TASK_AREA] = 2, 1, 1
    # -(2*0.05 + 0.2 + 0.3) + 2*0.5 - 0.001 = -0.6 + 1.0 - 0.001 = 0.399
    assert reaching_reward(contacts, eta, 0.5, True, w) == pytest.approx(0.399)
    # no target held: no time penalty, no reach
    assert reaching_reward([0] * N_KINDS, eta, None, False, w) == 0.0
    assert reaching_reward([0] * N_KINDS, eta, None, True, w) == pytest.approx(-0.001)


def test_ranking_scores_become_target_values():
    from cmdp_pymunk.evaluate import (
        DesiredPositionEvaluator,
        as_target_values,
        desired_position_values,
    )

    # Eq. 4 scores 1 - 2.83 .. 1 all become [0.5, 1] with the best at 1
    assert as_target_values({1: -1.0, 2: 0.0, 3: 1.0}) == pytest.approx({1: 0.5, 2: 0.75, 3: 1.0})

    class Crew:
        index, scope = 0, {0: -1, 1: -1}

    class Site:
        class case:  # noqa: N801
            class plane:  # noqa: N801
                half_extents = (10.0, 5.0)
        target_xy = [(5.0, 0.0), (-5.0, 2.5)]

    ev = DesiredPositionEvaluator(default=(0.5, 0.0))  # exactly on target 0: Eq. 4 gives 1
    values = ev.target_values(Crew, Site, (0.0, 0.0))
    assert values[0] == 1.0 and values[1] == 0.5

    # A desired position outside [-1, 1] is clipped first (a Gaussian sample can leave the
    # action space). A third target at (9, 4) m, (0.9, 0.8) over the half extents; from
    # (1, 0) Eq. 4 gives target 0 1 - 0.5 = 0.5, target 1 1 - hypot(1.5, 0.5) = -0.581,
    # target 2 1 - hypot(0.1, 0.8) = 0.194: V = 1, 0.5, 0.5 + 0.5 * 0.775 / 1.081 = 0.858.
    # Unclipped, (3, 0) would rank target 2 first (-1.247 against -1.5).
    class Crew3:
        index, scope = 0, {0: -1, 1: -1, 2: -1}

    class Site3(Site):
        target_xy = [(5.0, 0.0), (-5.0, 2.5), (9.0, 4.0)]

    values = desired_position_values((3.0, 0.0), Crew3, Site3)
    assert values == pytest.approx({0: 1.0, 1: 0.5, 2: 0.85838}, abs=1e-5)
    assert values == desired_position_values((1.0, 0.0), Crew3, Site3)
