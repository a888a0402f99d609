"""ROS bags in and out: ``azgym import bag`` and ``azgym export bag`` (docs/ros2.md).

:func:`import_bag` reads a ROS 1 or ROS 2 bag (sqlite3 or MCAP) and writes an azgym log;
:func:`export_bag` writes a log as a ROS 2 bag, in standard message types and REP-105 frames,
with azgym's own detection type (:data:`~azgym.logs.ros.messages.DETECTIONS_MSG`). Both go
through rosbags (``pip install "azgym[ros]"``), imported only when one runs.
"""

from azgym.logs.ros.read_bag import BagImport, import_bag
from azgym.logs.ros.write_bag import export_bag

__all__ = ["BagImport", "export_bag", "import_bag"]
