"""The notebook lane's outcomes as a pytest-xdist worker reads them (``helpers.lane.LaneOutcomes``): the outcome the
controller wrote, and a failure at once, not after the hour's deadline, when the lane's folder is removed mid-run."""

import json
import threading
import time

from helpers.lane import LaneOutcomes


def test_a_worker_reads_the_outcome_the_controller_wrote(tmp_path):
    (tmp_path / "lane").mkdir()
    (tmp_path / "lane" / "01_a.json").write_text(json.dumps([0, ["ran"]]))
    assert LaneOutcomes(["01_a"], tmp_path, deadline=5.0).wait("01_a") == (0, ["ran"])


def test_a_worker_stops_waiting_at_once_when_the_lanes_folder_is_removed(tmp_path):
    folder = tmp_path / "notebooks"
    folder.mkdir()
    lane = LaneOutcomes(["01_a"], folder, deadline=60.0)
    threading.Timer(0.3, folder.rmdir).start()
    start = time.monotonic()
    status, lines = lane.wait("01_a", poll=0.05)
    assert status == 1 and "was removed while the tests ran" in lines[0] and time.monotonic() - start < 5.0
