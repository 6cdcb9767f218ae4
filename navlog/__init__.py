"""navlog: record, replay, test and inspect mobile-robot navigation logs without ROS.

The code lives in three packages: ``navlog.recorder`` (producing logs), ``navlog.replay`` (running
nodes over message streams) and ``navlog.analysis`` (metrics, reports, views, export). This package
holds the version, the errors and the command line that ties them together.
"""

from navlog.version import __version__

__all__ = ["__version__"]
