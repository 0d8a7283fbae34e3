"""The precedence-cycle search (graphlib) names the cycle, in precedence order."""

from types import SimpleNamespace

import pytest
from conftest import tiny_dict

from cmdp_pymunk.cases.load import CaseError, _find_cycle, case_from_dict


def tasks(**preds):
    return [SimpleNamespace(id=k, predecessors=tuple(v)) for k, v in preds.items()]


def test_no_cycle_in_a_diamond():
    assert _find_cycle(tasks(A=[], B=["A"], C=["A"], D=["B", "C"])) is None


def test_cycle_starts_at_the_task_listed_first_and_reads_forwards():
    # D waits for C, C for B, B for D: the cycle B -> D -> C -> B (each ends before the next
    # starts), listed from B, the first of the three in the case; A and E are not part of it
    found = _find_cycle(tasks(A=[], B=["A", "C"], C=["D"], D=["B"], E=["D"]))
    assert found == ["B", "D", "C", "B"]


def test_two_task_cycle_and_self_reference_is_not_a_cycle():
    assert _find_cycle(tasks(X=["Y"], Y=["X"])) == ["X", "Y", "X"]
    assert _find_cycle(tasks(X=["X"])) is None  # reported as "precedes itself" instead


def test_cycle_is_named_in_the_case_error():
    data = tiny_dict()
    data["tasks"][0]["predecessors"] = ["K-A"]  # X-A -> K-A -> X-A
    with pytest.raises(CaseError) as caught:
        case_from_dict(data, "tiny.toml")
    (message,) = [p for p in caught.value.problems if "cycle" in p]
    assert message.startswith('tasks[0] "X-A": precedence cycle X-A -> K-A -> X-A')
    assert "fix: remove one of these predecessors" in message
