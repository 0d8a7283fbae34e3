"""The event log's CSV (cmdp_pymunk/events.py): a position's x, y and heading in their own
columns, read back to the same events, and the older layout still read."""

from conftest import make_log

from cmdp_pymunk.events import position, read_csv, write_atomic


def test_positions_have_their_own_columns():
    lines = make_log().to_csv().splitlines()
    assert lines[0] == "time_s,kind,crew,subject,detail,x_m,y_m,heading_deg"
    assert lines[1] == "0.0,activity,X-1,navigating,,,,"
    assert lines[5] == "0.0,position,X-1,,,-6.00,3.00,0"  # RUN's "-6.00,3.00,0"
    assert '"' not in "".join(lines)  # nothing quoted: one value per column


def test_read_csv_gives_back_the_logged_events(tmp_path):
    log = make_log()
    log.write_csv(tmp_path / "events.csv")
    events = read_csv(tmp_path / "events.csv")
    assert events == log.events
    assert position(events[6]) == (-5.0, 2.0, 300.0)  # X-1 at 5 s


def test_read_csv_reads_the_layout_without_position_columns(tmp_path):
    write_atomic(tmp_path / "old.csv", 'time_s,kind,crew,subject,detail\n'
                 '5.0,position,X-1,"-5.00,2.00,300",\n7.0,task_start,X-1,X-A,\n')
    first, second = read_csv(tmp_path / "old.csv")
    assert position(first) == (-5.0, 2.0, 300.0) and second.subject == "X-A"
