"""The schedule of an event log (cmdp_pymunk/schedule.py), on the hand-made log of
``conftest.RUN`` and the tiny case of conftest.py: X-A 10-130 and X-B 160-280 by X-1, K-A
160-300 by K-1, M-C 370-500 by M-1 with one pause 400-440."""

import numpy as np
from conftest import RUN, make_events

from cmdp_pymunk import schedule


def test_task_bars_by_hand():
    bars = schedule.task_bars(make_events())
    # Sorted by start; X-B and K-A both start at 160 and keep the log's order.
    assert [b.task for b in bars] == ["X-A", "X-B", "K-A", "M-C"]
    assert [b.crew for b in bars] == ["X-1", "X-1", "K-1", "M-1"]
    assert [b.segments for b in bars] == [((10, 130),), ((160, 280),), ((160, 300),),
                                          ((370, 400), (440, 500))]
    mc = bars[-1]
    assert mc.pauses == ((400, 440),)
    assert (mc.start_s, mc.end_s, mc.finished) == (370, 500, True)


def test_task_bars_of_a_log_cut_short():
    # M-C paused at 400 and the log ends at 420; X-A still running at the end.
    events = make_events([(0, "task_start", "X-1", "X-A"),
                          (370, "task_start", "M-1", "M-C"),
                          (400, "task_pause", "M-1", "M-C"),
                          (420, "activity", "M-1", "fetching")])
    bars = {b.task: b for b in schedule.task_bars(events)}
    assert bars["X-A"].segments == ((0, 420),) and not bars["X-A"].finished
    assert bars["M-C"].segments == ((370, 400),) and not bars["M-C"].finished
    assert bars["M-C"].pauses == ()


def test_makespan_log_end_and_finish_times():
    events = make_events()
    assert schedule.makespan_s(events) == 500  # M-C's finish
    assert schedule.log_end_s(events) == 540
    assert schedule.makespan_s(make_events(RUN[:5])) is None
    assert schedule.finish_times(events) == [130, 280, 300, 500]


def test_schedule_csv_by_hand(tiny_case):
    # duration = end - start, pauses included: M-C 500 - 370 = 130 (worked 90, paused 40)
    assert schedule.schedule_csv(make_events(), tiny_case).splitlines() == [
        "task,crew,start_s,end_s,pauses,paused_s,finished,task_type,component,status,"
        "duration_s",
        "X-A,X-1,10,130,0,0,true,X,A,end,120",
        "X-B,X-1,160,280,0,0,true,X,B,end,120",
        "K-A,K-1,160,300,0,0,true,K,A,end,140",
        "M-C,M-1,370,500,1,40,true,M,C,end,130",  # paused 400-440
    ]


def test_schedule_csv_of_an_unfinished_task_has_no_end(tiny_case):
    events = make_events([(0, "task_start", "X-1", "X-A"),
                          (100, "task_pause", "X-1", "X-A"),
                          (130, "task_resume", "X-1", "X-A"),
                          (150, "activity", "X-1", "tasking")])
    # worked 0-100 and 130-150 (the log's end): one pause of 30 s, no finish, still on
    rows = schedule.schedule_csv(events, tiny_case).splitlines()[1:]
    assert rows[0] == "X-A,X-1,0,,1,30,false,X,A,on,"
    # the tasks that never started, in the case's order: X-B has no predecessor (queue), K-A
    # waits for X-A and M-C for K-A (wait)
    assert rows[1:] == ["K-A,,,,0,0,false,K,A,wait,", "X-B,,,,0,0,false,X,B,queue,",
                        "M-C,,,,0,0,false,M,C,wait,"]


def test_schedule_csv_of_a_run_that_stalled_with_a_task_paused(tiny_case):
    """``conftest.RUN`` cut at 400 s, M-1 walking to fetch bars after pausing M-C at 400, and
    the run stopped (stalled) at 460 s: M-C is on, paused once for 460 - 400 = 60 s."""
    events = make_events([r for r in RUN if r[0] <= 400])
    rows = schedule.schedule_csv(events, tiny_case, end_s=460).splitlines()[1:]
    assert rows == ["X-A,X-1,10,130,0,0,true,X,A,end,120",
                    "X-B,X-1,160,280,0,0,true,X,B,end,120",
                    "K-A,K-1,160,300,0,0,true,K,A,end,140",
                    "M-C,M-1,370,,1,60,false,M,C,on,"]
    # without the stop, the pause runs to the log's last event (400): 0 s, still counted
    assert schedule.schedule_csv(events, tiny_case).splitlines()[-1] == \
        "M-C,M-1,370,,1,0,false,M,C,on,"


def test_schedule_csv_of_a_run_that_never_started_a_task(tiny_case):
    events = make_events(RUN[:7])  # activities and positions up to 5 s, no task event
    assert schedule.schedule_csv(events, tiny_case, end_s=200).splitlines()[1:] == [
        "X-A,,,,0,0,false,X,A,queue,", "K-A,,,,0,0,false,K,A,wait,",
        "X-B,,,,0,0,false,X,B,queue,", "M-C,,,,0,0,false,M,C,wait,"]


def test_schedule_csv_with_a_calendar_dates_across_a_weekend_and_a_holiday(tiny_case):
    """Second 0 is Fri 2026-01-09 15:55, days 08:00-16:00 Mon-Fri, Mon 12th a holiday: second
    300 is Friday's closing (16:00) and second 370 is 70 s into Tue 13th (08:01:10)."""
    from cmdp_pymunk.cases.model import Calendar

    case = tiny_case.model_copy(update={"calendar": Calendar(
        start="2026-01-09T15:55", working_hours="08:00-16:00", working_days="Mon-Fri",
        holidays=["2026-01-12"])})
    assert schedule.schedule_csv(make_events(), case).splitlines() == [
        "task,crew,start_s,end_s,pauses,paused_s,finished,task_type,component,status,"
        "duration_s,start,end",
        "X-A,X-1,10,130,0,0,true,X,A,end,120,2026-01-09T15:55:10,2026-01-09T15:57:10",
        "X-B,X-1,160,280,0,0,true,X,B,end,120,2026-01-09T15:57:40,2026-01-09T15:59:40",
        "K-A,K-1,160,300,0,0,true,K,A,end,140,2026-01-09T15:57:40,2026-01-09T16:00:00",
        # 500 - 300 = 200 s into Tuesday: 08:03:20
        "M-C,M-1,370,500,1,40,true,M,C,end,130,2026-01-13T08:01:10,2026-01-13T08:03:20",
    ]
    # unfinished: no end date; never started: neither
    rows = schedule.schedule_csv(make_events([r for r in RUN if r[0] <= 400]), case,
                                 end_s=460).splitlines()
    assert rows[-1] == "M-C,M-1,370,,1,60,false,M,C,on,,2026-01-13T08:01:10,"
    rows = schedule.schedule_csv(make_events(RUN[:7]), case, end_s=200).splitlines()
    assert rows[1] == "X-A,,,,0,0,false,X,A,queue,,,"


def test_task_pools_replay_the_flow(tiny_case):
    from cmdp_pymunk.precedence import Pool

    # at 300 s: X-A, X-B and K-A ended, so M-C (after K-A) is in the queue
    at_300 = schedule.task_pools(make_events([r for r in RUN if r[0] <= 300]), tiny_case)
    assert at_300 == {"X-A": Pool.END, "K-A": Pool.END, "X-B": Pool.END, "M-C": Pool.QUEUE}
    # at 160 s: X-A ended, X-B and K-A just started, M-C waits for K-A
    at_160 = schedule.task_pools(make_events([r for r in RUN if r[0] <= 160]), tiny_case)
    assert at_160 == {"X-A": Pool.END, "K-A": Pool.ON, "X-B": Pool.ON, "M-C": Pool.WAIT}
    assert schedule.paused_at_end(make_events([r for r in RUN if r[0] <= 400])) == {"M-C": 400}
    assert schedule.paused_at_end(make_events()) == {}  # M-C resumed and finished


def test_tasks_ended_counts_finishes_at_or_before_each_time():
    ended = schedule.tasks_ended([[130, 280, 300, 500], [200]], np.array([0, 130, 299, 500]))
    assert ended.tolist() == [[0, 1, 2, 4], [0, 0, 1, 1]]
    assert schedule.tasks_ended([], np.array([0.0, 1.0])).shape == (0, 2)
