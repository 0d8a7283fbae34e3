"""Table 1 row by row on the tiny case, and the states where two triggers would hold at once."""

import itertools

import pytest
from conftest import place

from cmdp_pymunk import construct, decide
from cmdp_pymunk.state import CrewStatus, IdleCause, Pool, ScopeKind

X1, K1, M1, M2 = range(4)  # crews of the tiny case
XA, KA, XB, MC = range(4)  # tasks
A, B, C = range(3)  # components


def ctx_of(env):
    engine = env.engine
    return decide.Context(engine.site, engine.world, engine.positions, engine.streams, env.log)


def fire(env, crew_index):
    """The first row whose trigger holds, applied; returns its code."""
    ctx = ctx_of(env)
    crew = env.engine.site.crews[crew_index]
    rule = decide.first_rule(crew, ctx)
    assert rule is not None
    rule.effect(crew, ctx)
    return rule.code


def test_table_has_the_ten_rows_of_table_1():
    assert sorted(r.code for r in decide.DECISION_TABLE) == sorted(f"c{i}" for i in range(1, 11))


def test_c10_acquire_target_at_reset(tiny_env):
    crews = tiny_env.engine.site.crews
    # both X tasks are queued -> scope is components A and B
    assert crews[X1].scope_kind == ScopeKind.TASKS and set(crews[X1].scope) == {A, B}
    # K-1: K-A waits for X-A -> idle for a predecessor
    assert crews[K1].scope_kind == ScopeKind.NONE
    assert crews[K1].idle_cause == IdleCause.PREDECESSOR
    # M-1 needs bars and holds none -> its scope is the storage
    assert crews[M1].scope_kind == ScopeKind.STORAGES
    assert set(crews[M1].scope) == {tiny_env.engine.site.storages[0].target}
    assert all(c.values.keys() == c.scope.keys() for c in crews)  # evaluated


def test_c1_initiate_task(tiny_env):
    env = tiny_env
    place(env, X1, -4.5, 0.0)  # inside X-A's area (-5, -2, -1, 2), outside component A
    assert fire(env, X1) == "c1"
    task, crew = env.engine.site.tasks[XA], env.engine.site.crews[X1]
    assert task.pool == Pool.ON and crew.status == CrewStatus.TASKING and crew.task == XA
    assert XA in env.engine.world.area_shapes and env.engine.site.active_areas == [XA]
    assert task.pace == pytest.approx(1.0 / 120.0, rel=0.5)  # 2 min per task, sd 0.3 min


def test_c2_execute_then_c9_complete(tiny_env):
    env = tiny_env
    place(env, X1, -4.5, 0.0)
    fire(env, X1)
    task = env.engine.site.tasks[XA]
    assert fire(env, X1) == "c2"
    construct.advance(env.engine.site, env.engine.positions, env.log, 1.0)
    assert task.progress == pytest.approx(task.pace)
    task.progress = task.work
    assert fire(env, X1) == "c9"
    site = env.engine.site
    assert task.pool == Pool.END and site.tasks[KA].pool == Pool.QUEUE  # successor released
    assert XA not in env.engine.world.area_shapes and site.crews[X1].status == CrewStatus.REACHING


def test_c8_request_crane_for_task(tiny_env):
    env = tiny_env
    env.engine.site.tasks[XA].pool = Pool.END
    env.engine.site.tasks[KA].pool = Pool.QUEUE
    env.engine.site.version += 1
    assert fire(env, K1) == "c10"
    place(env, K1, -5.0, 0.0)
    assert fire(env, K1) == "c1"
    assert fire(env, K1) == "c8"
    assert env.engine.site.crews[K1].status == CrewStatus.WAITING
    assert env.engine.site.crane.current is not None and env.engine.site.crane.current.crew == K1
    for _ in range(29):  # assist_time_s = 30: the idle crane set off at the request
        construct.advance(env.engine.site, env.engine.positions, env.log, 1.0)
    assert env.engine.site.crews[K1].status == CrewStatus.WAITING
    construct.advance(env.engine.site, env.engine.positions, env.log, 1.0)
    site = env.engine.site
    assert site.tasks[KA].crane_assisted and site.crews[K1].status == CrewStatus.TASKING


def _start_mc(env, crew_index=M1, load=0.1):
    site = env.engine.site
    for t in (XA, KA):
        site.tasks[t].pool = Pool.END
    site.tasks[MC].pool = Pool.QUEUE
    site.version += 1
    crew = site.crews[crew_index]
    crew.load = load
    crew.clear_scope()  # as after c6: loaded, no scope
    assert fire(env, crew_index) == "c10" and crew.scope_kind == ScopeKind.TASKS
    place(env, crew_index, 0.5, 1.2)  # inside M-C's area (-0.5, -1.5, 1.5, 1.5)
    assert fire(env, crew_index) == "c1"
    return crew


def test_c3_pause_when_material_runs_out(tiny_env):
    env = tiny_env
    crew = _start_mc(env)
    crew.load = 0.0
    assert fire(env, M1) == "c3"
    assert crew.paused and crew.status == CrewStatus.REACHING
    assert crew.scope_kind == ScopeKind.STORAGES
    assert env.engine.site.tasks[MC].pool == Pool.ON  # the area stays
    assert MC in env.engine.world.area_shapes


def test_c7_c5_c6_c4_fetch_cycle(tiny_env):
    env = tiny_env
    site = tiny_env.engine.site
    crew = _start_mc(env)
    crew.load = 0.0
    fire(env, M1)  # c3
    place(env, M1, 6.0, 4.5)  # inside the storage, which is empty
    assert fire(env, M1) == "c7"
    assert crew.status == CrewStatus.WAITING and site.storages[0].lift_pending
    for _ in range(59):  # lift_time_s = 60
        construct.advance(site, env.engine.positions, env.log, 1.0)
    assert site.storages[0].stock == 0.0 and crew.status == CrewStatus.WAITING
    construct.advance(site, env.engine.positions, env.log, 1.0)
    assert site.storages[0].stock == pytest.approx(0.5) and crew.status == CrewStatus.FETCHING
    for _ in range(20):  # 0.6 m3/min = 0.01 m3/s, capacity 0.2 -> 20 s
        construct.advance(site, env.engine.positions, env.log, 1.0)
    assert crew.load == pytest.approx(0.2)
    assert fire(env, M1) == "c6"
    assert crew.scope_kind == ScopeKind.PAUSED and crew.scope == {C: MC}
    place(env, M1, 0.5, 1.2)
    assert fire(env, M1) == "c4"
    assert crew.status == CrewStatus.TASKING and not crew.paused


def test_c6_without_a_paused_task_acquires_tasks_at_once(tiny_env):
    env = tiny_env
    crew = env.engine.site.crews[M1]
    env.engine.site.storages[0].stock = 0.5
    place(env, M1, 6.0, 4.5)
    fire(env, M1)  # c5
    crew.load = crew.capacity
    assert fire(env, M1) == "c6"
    # no task of its type is queued yet (M-C waits for K-A): idle for a predecessor, at once
    assert fire(env, M1) == "c10" and crew.idle_cause == IdleCause.PREDECESSOR


def test_c5_fetch_at_a_stocked_storage(tiny_env):
    env = tiny_env
    env.engine.site.storages[0].stock = 0.5
    place(env, M1, 6.0, 4.5)
    assert fire(env, M1) == "c5"
    assert env.engine.site.crews[M1].status == CrewStatus.FETCHING


def test_c7_while_fetching_when_stock_runs_out(tiny_env):
    env = tiny_env
    crew = env.engine.site.crews[M1]
    env.engine.site.storages[0].stock = 0.05
    place(env, M1, 6.0, 4.5)
    fire(env, M1)  # c5
    for _ in range(6):
        construct.advance(env.engine.site, env.engine.positions, env.log, 1.0)
    assert crew.load == pytest.approx(0.05) and env.engine.site.storages[0].stock == 0.0
    assert fire(env, M1) == "c7" and crew.status == CrewStatus.WAITING


def test_c10_deregisters_to_the_outlet_when_no_work_remains(tiny_env):
    env = tiny_env
    for t in (XA, XB):
        env.engine.site.tasks[t].pool = Pool.END
    env.engine.site.version += 1
    assert fire(env, X1) == "c10"
    crew = env.engine.site.crews[X1]
    assert crew.status == CrewStatus.DEREGISTERED and crew.scope_kind == ScopeKind.OUTLET


def test_c10_idle_when_task_areas_block(tiny_env):
    env = tiny_env
    _start_mc(env, crew_index=M1)  # M-C is on; M-2 has nothing else
    crew = env.engine.site.crews[M2]
    crew.load = 0.1
    crew.clear_scope()
    fire(env, M2)
    # M-2's only task is being worked by M-1: not queued any more -> nothing remains -> outlet
    assert crew.status == CrewStatus.DEREGISTERED
    # X-B conflicts with nothing; put an area over X-B by hand and X-1 reports AREA
    env.engine.site.tasks[XA].pool = Pool.END
    env.engine.site.tasks[XB].conflicts = (MC,)
    env.engine.site.version += 1
    fire(env, X1)
    assert env.engine.site.crews[X1].idle_cause == IdleCause.AREA


def test_no_state_fires_two_rows():
    """Enumerate crew states; list every one where two triggers hold at once (none may)."""
    import sys

    sys.path.insert(0, "tests")
    from conftest import tiny_dict

    from cmdp_pymunk import parallel_env
    from cmdp_pymunk.cases.load import case_from_dict

    env = parallel_env(case=case_from_dict(tiny_dict()), seed=0)
    env.reset(seed=0)
    site, crew = env.engine.site, env.engine.site.crews[M1]
    task, storage = site.tasks[MC], site.storages[0]
    task.needs_crane = True  # one task that needs both material and the crane
    overlaps = []
    grid = itertools.product(
        [s for s in CrewStatus if s != CrewStatus.LEFT], ScopeKind, (False, True),
        (False, True), (0.0, 0.1, 0.2), (False, True), (False, True), (0.0, 0.5),
        (False, True), (Pool.QUEUE, Pool.ON))
    for status, kind, paused, reached, load, done, assisted, stock, current, pool in grid:
        crew.status, crew.scope_kind, crew.paused, crew.load = status, kind, paused, load
        crew.task = MC if status in (CrewStatus.TASKING, CrewStatus.WAITING) or paused else -1
        crew.storage = 0 if status in (CrewStatus.FETCHING, CrewStatus.WAITING) else -1
        crew.scope = {storage.target: -1} if kind == ScopeKind.STORAGES else \
            {site.outlet_target: -1} if kind == ScopeKind.OUTLET else \
            {C: MC} if kind in (ScopeKind.TASKS, ScopeKind.PAUSED) else {}
        crew.scope_version = site.version if current else -1
        task.progress = task.work if done else 0.0
        task.crane_assisted, task.pool, storage.stock = assisted, pool, stock
        ctx = ctx_of(env)
        ctx.reached[M1] = next(iter(crew.scope)) if reached and crew.scope else -1
        hits = [r.code for r in decide.DECISION_TABLE if r.trigger(crew, ctx)]
        indexed = {r.code for r in decide.ROWS_BY_STATUS[status]}
        assert set(hits) <= indexed, (status.name, hits)
        tried = {r.code for r in decide.ROWS_BY_STATE[status, kind]}  # a reaching crew's by kind
        assert set(hits) <= tried, (status.name, kind.name, hits)
        if len(hits) > 1:
            overlaps.append((status.name, kind.name, paused, reached, load, done, assisted,
                             stock, current, pool.name, hits))
    assert not overlaps, "states where two rows trigger:\n" + "\n".join(map(str, overlaps[:20]))


def test_table_prints_as_markdown():
    text = decide.table_as_markdown()
    assert text.count("\n") == 11 and "Initiate task" in text


def test_waiting_and_deregistered_crews_try_no_row():
    # (that no row triggers outside its indexed states is checked on every enumerated state
    # in test_no_state_fires_two_rows)
    assert decide.ROWS_BY_STATUS[CrewStatus.WAITING] == ()
    assert decide.ROWS_BY_STATUS[CrewStatus.DEREGISTERED] == ()


def test_execution_is_the_last_row_its_crews_try():
    """``apply_decision_table`` settles a crew when c2 fires: that no other row would fire
    holds only while c2 is the last row of every state (and scope kind) it is tried in."""
    c2 = next(r for r in decide.DECISION_TABLE if r.code == "c2")
    holders = [rows for rows in decide.ROWS_BY_STATE.values() if c2 in rows]
    assert holders and all(rows[-1] is c2 for rows in holders)


def test_a_tasking_crews_rows_read_at_once_agree_with_the_table(tiny_env):
    """``decide._only_execution`` (the table's fast path for a tasking crew) holds exactly
    when the rows' own triggers give c2 first, over every combination of what they read."""
    env = tiny_env
    ctx = ctx_of(env)
    crew = env.engine.site.crews[M1]
    task = env.engine.site.tasks[MC]
    crew.status, crew.task = CrewStatus.TASKING, MC
    seen = set()
    for done, per_work, load, needs, assisted in itertools.product(
            (False, True), (0.0, 0.5), (0.0, 2.0), (False, True), (False, True)):
        task.progress = task.work if done else 0.0
        task.material_per_work, crew.load = per_work, load
        task.needs_crane, task.crane_assisted = needs, assisted
        first = decide.first_rule(crew, ctx)
        seen.add(first.code)
        assert decide._only_execution(crew, task) == (first.code == "c2")
    assert seen == {"c9", "c3", "c8", "c2"}  # every tasking row was met
