"""A seed's result travels from a worker to the writing process as columns
(``SeedRun.__reduce__``): the same events come back, as ``Event`` tuples, and a stuck seed's
empty log too."""

from __future__ import annotations

import pickle

from conftest import make_events

from cmdp_pymunk.events import Event
from training.runs.seed_outputs import SeedRun


def test_a_seed_run_comes_back_the_same():
    events = make_events()
    run = SeedRun(3, {"makespan_s": 500.0, "crews": [{"id": "X-1"}]}, events)
    back = pickle.loads(pickle.dumps(run, protocol=pickle.HIGHEST_PROTOCOL))
    assert back == run and back.events == events
    assert all(type(e) is Event for e in back.events)
    assert back.events[4].kind == "position" and back.events[4].subject == "-6.00,3.00,0"
    stuck = SeedRun(4, None, [], "the low level got stuck")
    assert pickle.loads(pickle.dumps(stuck)) == stuck
