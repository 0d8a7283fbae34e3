"""The lookahead (agents.lookahead): plumbing, not learning."""

from __future__ import annotations

import json

import pytest
from conftest import event_floor, play, play_floor

import cmdp_pymunk
from agents.lookahead import LookaheadEvaluator, LookaheadSettings, promote, ranked
from agents.navigator import Navigator
from agents.priority import PriorityEvaluator
from agents.specs import evaluator_from_spec
from cmdp_pymunk.streams import EXPECTED


def test_promote_swaps_the_chosen_target_with_the_best():
    values = {3: 0.5, 4: 1.0, 7: 0.75}
    assert promote(values, 7) == {3: 0.5, 4: 0.75, 7: 1.0}
    assert promote(values, 4) == values
    assert ranked({1: 0.9, 2: 0.9, 0: 0.5}) == [1, 2, 0]  # ties: lowest index first


def test_one_candidate_is_the_base_rule_exactly(priority_floor):
    # (racing settings too: with one candidate there is no race either)
    lookahead = LookaheadEvaluator(settings=LookaheadSettings(candidates=1, futures=4, race=2))
    floor = event_floor(lookahead)
    base = priority_floor
    assert floor.site.done and floor.makespan_s == base.makespan_s
    assert floor.log.events == base.log.events
    assert lookahead.decisions == []


class Recording(LookaheadEvaluator):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.calls = []

    def branch_makespan(self, engine, i, values, target, scenario):
        self.calls.append((len(self.decisions), engine.site.time_s, target, scenario))
        return super().branch_makespan(engine, i, values, target, scenario)


def test_candidates_meet_the_same_sampled_futures(tiny_case):
    lookahead = Recording(settings=LookaheadSettings(candidates=2, futures=2))
    env = play_floor(lookahead, tiny_case)
    assert env.engine.site.done and lookahead.decisions
    by_decision: dict = {}
    for decision, _, target, scenario in lookahead.calls:
        by_decision.setdefault(decision, {}).setdefault(target, []).append(scenario)
    seen = []
    for futures in by_decision.values():
        assert len(futures) == 2  # both candidates tried
        first, second = futures.values()
        assert first == second and len(first) == 2  # the same two futures for each
        seen += first
    assert len(set(seen)) == len(seen)  # a new pair of futures for each decision
    for d in lookahead.decisions:  # the choice is the lowest mean makespan
        assert d.makespans_s[d.candidates.index(d.choice)] == min(d.makespans_s)


def test_expected_paces_branch_once_per_candidate_into_the_same_future(tiny_case):
    lookahead = Recording(settings=LookaheadSettings(candidates=2, expected_paces=True))
    env = play_floor(lookahead, tiny_case)
    assert env.engine.site.done and lookahead.decisions
    assert {scenario for *_, scenario in lookahead.calls} == {EXPECTED}
    per_decision = [sum(1 for d, *_ in lookahead.calls if d == k)
                    for k in range(len(lookahead.decisions))]
    assert per_decision == [2] * len(lookahead.decisions)  # one branch per candidate
    assert lookahead.summary()["futures"] == "expected"


def test_the_true_future_branch_replays_the_floor(tiny_case):
    # futures=0 branches into the floor's own future: the branch that takes the base rule's
    # choice is the base rule's floor itself
    lookahead = LookaheadEvaluator(settings=LookaheadSettings(candidates=2, futures=0))
    play_floor(lookahead, tiny_case)
    base = play_floor(PriorityEvaluator(), tiny_case)
    first = lookahead.decisions[0]
    assert first.makespans_s[first.candidates.index(first.base_choice)] == base.makespan_s


def test_lookahead_specs_and_their_errors():
    ev = evaluator_from_spec("lookahead:candidates=2+futures=0+base=nearest")
    assert isinstance(ev, LookaheadEvaluator) and ev.settings == LookaheadSettings(2, 0)
    assert type(ev.base).__name__ == "NearestFirstEvaluator"
    assert evaluator_from_spec("lookahead").settings == LookaheadSettings()
    with pytest.raises(ValueError, match="candidates=INT, futures=INT or expected, "
                                         "workers=INT, race=INT, base=SPEC"):
        evaluator_from_spec("lookahead:cands=2")
    expected = evaluator_from_spec("lookahead:futures=expected")
    assert expected.settings == LookaheadSettings(futures=1, expected_paces=True)
    with pytest.raises(ValueError, match="futures must be 1"):
        LookaheadSettings(futures=2, expected_paces=True)
    with pytest.raises(ValueError, match="branch inside branches"):
        evaluator_from_spec("lookahead:base=lookahead")
    with pytest.raises(ValueError, match="candidates must be an int >= 1"):
        LookaheadSettings(candidates=0)


def test_the_lookahead_needs_no_binding_and_branches_the_engine_alone(tiny_case):
    """Nothing to bind: the engine asks the lookahead between seconds and the branches play
    on clones of the engine with the lookahead's own low level."""
    lookahead = LookaheadEvaluator(settings=LookaheadSettings(candidates=2, futures=1))
    env = cmdp_pymunk.parallel_env(case=tiny_case, seed=0, evaluator=lookahead)
    env.reset(seed=0)
    play(env, Navigator(), None)
    assert env.makespan_s is not None and lookahead.decisions
    assert all(len(d.makespans_s) == len(d.candidates) >= 2 for d in lookahead.decisions)


def test_cmdp_simulate_runs_the_lookahead(tmp_path):
    from training.commands import simulate

    out = tmp_path / "run"
    assert simulate.main(["--case", str(cmdp_pymunk.TINY_CASE), "--out", str(out),
                          "--evaluator", "lookahead:candidates=2+futures=1", "--no-charts",
                          "--no-progress"]) == 0
    data = json.loads((out / "summary.json").read_text())
    assert data["all_finished"] and data["lookahead"]["candidates"] == 2


@pytest.mark.slow  # spawning two workers costs more than the rest of this file
def test_worker_processes_choose_as_this_process_does(tiny_case):
    one = LookaheadEvaluator(settings=LookaheadSettings(candidates=2, futures=2))
    two = LookaheadEvaluator(settings=LookaheadSettings(candidates=2, futures=2, workers=2))
    try:
        env_one, env_two = play_floor(one, tiny_case), play_floor(two, tiny_case)
    finally:
        two.close()
    assert [(d.candidates, d.makespans_s, d.choice) for d in one.decisions] == \
        [(d.candidates, d.makespans_s, d.choice) for d in two.decisions]
    assert env_one.log.events == env_two.log.events


def test_racing_drops_what_is_clearly_behind_and_keeps_the_futures_paired(tiny_case):
    """Two candidates from 2 futures each up to 8: each round every survivor meets a prefix
    of the decision's futures (paired); a candidate stops early only where its paired
    difference to the other is clearly positive (recomputed here by hand), and the choice
    met the most futures."""
    import numpy as np
    from scipy.stats import t as student_t

    lookahead = Recording(settings=LookaheadSettings(candidates=2, futures=8, race=2))
    made: list = []
    original = LookaheadEvaluator.branch_makespan

    def recorded(self, engine, i, values, target, scenario):
        made.append((len(self.decisions), target, original(self, engine, i, values, target,
                                                            scenario)))
        return made[-1][2]

    lookahead.branch_makespan = recorded.__get__(lookahead)
    env = play_floor(lookahead, tiny_case)
    assert env.engine.site.done and lookahead.decisions
    for k, d in enumerate(lookahead.decisions):
        seen = {c: [m for dk, t, m in made if dk == k and t == c] for c in d.candidates}
        assert [len(seen[c]) for c in d.candidates] == d.futures_seen
        assert set(d.futures_seen) <= {2, 4, 8}
        assert len(seen[d.choice]) == max(d.futures_seen)
        short = [c for c in d.candidates if len(seen[c]) < max(d.futures_seen)]
        for c in short:  # stopped: clearly behind the choice on the futures both met
            n = len(seen[c])
            diffs = np.subtract(seen[c], seen[d.choice][:n])
            assert diffs.mean() > student_t.ppf(0.975, n - 1) * diffs.std(ddof=1) / n ** 0.5
        if len(set(d.futures_seen)) == 1 and d.futures_seen[0] < 8:  # stopped early: clear
            n = d.futures_seen[0]
            loser = next(c for c in d.candidates if c != d.choice)
            assert np.mean(seen[loser]) > np.mean(seen[d.choice])
    assert lookahead.summary()["branches"] == len(made)


def test_racing_over_as_many_futures_as_it_starts_with_is_the_plain_lookahead(tiny_case):
    plain = LookaheadEvaluator(settings=LookaheadSettings(candidates=2, futures=2))
    racing = LookaheadEvaluator(settings=LookaheadSettings(candidates=2, futures=2, race=2))
    a, b = play_floor(plain, tiny_case), play_floor(racing, tiny_case)
    assert a.makespan_s == b.makespan_s and a.log.events == b.log.events
    assert [d.makespans_s for d in plain.decisions] == [d.makespans_s for d in racing.decisions]
    assert isinstance(evaluator_from_spec("lookahead:candidates=3+futures=8+race=2"),
                      LookaheadEvaluator)
    with pytest.raises(ValueError, match="futures >= race"):
        LookaheadSettings(futures=2, race=4)
    with pytest.raises(ValueError, match="an interval needs two"):
        LookaheadSettings(futures=8, race=1)



def test_an_endgame_lookahead_decides_only_once_its_share_of_tasks_has_ended(tiny_case):
    """``from_share``: no decision before that share of the tasks has ended (the base rule's
    floor until then), decisions after it; ``from=SHARE`` in the spec, checked."""
    everywhere = LookaheadEvaluator(settings=LookaheadSettings(candidates=2, futures=0))
    play_floor(everywhere, tiny_case)
    assert everywhere.decisions

    endgame = Recording(settings=LookaheadSettings(candidates=2, futures=0, from_share=0.5))
    ended: list = []
    original = Recording.decide

    def watched(self, engine, i, values):
        decision = original(self, engine, i, values)
        if decision is not None:
            ended.append(engine.site.tasks_ended / len(engine.site.tasks))
        return decision

    endgame.decide = watched.__get__(endgame)
    env = play_floor(endgame, tiny_case)
    assert env.engine.site.done
    assert all(share >= 0.5 for share in ended)
    assert len(endgame.decisions) < len(everywhere.decisions)
    late = LookaheadEvaluator(settings=LookaheadSettings(candidates=2, futures=0,
                                                         from_share=0.99))
    alone = play_floor(late, tiny_case)
    assert late.decisions == [] and alone.log.events == play_floor(
        PriorityEvaluator(), tiny_case).log.events
    spec = evaluator_from_spec("lookahead:candidates=2+futures=4+race=2+from=0.7")
    assert spec.settings.from_share == 0.7
    for bad in ("from=1", "from=-0.1", "from=x"):
        with pytest.raises(ValueError, match="from=SHARE"):
            evaluator_from_spec(f"lookahead:{bad}")
    with pytest.raises(ValueError, match=r"from_share must be in \[0, 1\)"):
        LookaheadSettings(from_share=1.0)
