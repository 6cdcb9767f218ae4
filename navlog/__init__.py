"""navlog: record, replay, test and inspect mobile-robot navigation logs without ROS.

The code lives in three packages: ``recorder`` (producing logs), ``replay`` (running nodes over
message streams) and ``analysis`` (metrics, reports, views, export). This package holds only the
version and the command line that ties them together.
"""

from replay import __version__  # noqa: F401  (one version for the distribution)
