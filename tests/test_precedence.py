"""The pool flow wait -> queue -> on -> end on the tiny three-component case."""

from cmdp_pymunk import precedence
from cmdp_pymunk.state import Pool, Site

XA, KA, XB, MC = range(4)


def test_pools_flow_with_precedence(tiny_case):
    site = Site(tiny_case, stage=2)
    pools = lambda: [t.pool for t in site.tasks]  # noqa: E731
    assert pools() == [Pool.QUEUE, Pool.WAIT, Pool.QUEUE, Pool.WAIT]
    precedence.start(site, site.tasks[XA])
    assert pools() == [Pool.ON, Pool.WAIT, Pool.QUEUE, Pool.WAIT]
    assert precedence.component_attributes(site, 0) == ((), "X")
    released = precedence.finish(site, site.tasks[XA])
    assert [t.id for t in released] == ["K-A"]
    assert precedence.component_attributes(site, 0) == (("K",), None)
    precedence.start(site, site.tasks[KA])
    precedence.finish(site, site.tasks[KA])
    assert pools() == [Pool.END, Pool.END, Pool.QUEUE, Pool.QUEUE]
    assert site.tasks_ended == 2 and not site.done


def test_successor_counts_and_space_conflicts(tiny_case):
    site = Site(tiny_case, stage=2)
    # X-A -> K-A -> M-C: X-A has two successors in all, K-A one, M-C none
    assert [t.all_successors for t in site.tasks] == [2, 1, 0, 0]
    # K-A's area (A grown by 1.5 m: x -5.5..-0.5) overlaps M-C's (C grown by 1 m: x -1..2);
    # X-A's area (A grown by 1 m: x -5..-1) only touches it at x = -1: no conflict
    assert MC in site.tasks[KA].conflicts and KA in site.tasks[MC].conflicts
    assert MC not in site.tasks[XA].conflicts
    # tasks on the same component always conflict
    assert KA in site.tasks[XA].conflicts and XA in site.tasks[KA].conflicts


def test_space_conflicts_are_the_pairwise_overlaps():
    """The site finds every pair at once (``state.overlaps``): the pairs ``overlap`` finds one
    by one, in task order, as plain ints, on the built-in case."""
    import cmdp_pymunk
    from cmdp_pymunk.state import overlap

    site = Site(cmdp_pymunk.load_case(), stage=2)
    want = [tuple(o.index for o in site.tasks if o is not t and overlap(t.area, o.area))
            for t in site.tasks]
    assert [t.conflicts for t in site.tasks] == want
    assert all(type(o) is int for t in site.tasks for o in t.conflicts)
    assert sum(map(len, want)) > len(site.tasks)


def test_a_task_waits_until_every_predecessor_ends(tiny_case):
    from conftest import tiny_dict

    from cmdp_pymunk.cases.load import case_from_dict

    data = tiny_dict()
    data["tasks"][3]["predecessors"] = ["K-A", "X-B"]
    site = Site(case_from_dict(data), stage=2)
    for t in (XA, KA):
        precedence.start(site, site.tasks[t])
        precedence.finish(site, site.tasks[t])
    assert site.tasks[MC].pool == Pool.WAIT
    precedence.start(site, site.tasks[XB])
    precedence.finish(site, site.tasks[XB])
    assert site.tasks[MC].pool == Pool.QUEUE
