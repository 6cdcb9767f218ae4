"""Navigation campaigns: one or more Nav2 configurations across many worlds, robots, routes and seeds.

- ``run_campaign`` (``navlog campaign run CAMPAIGN.yaml -o OUT``): plans the runs of a campaign file
  (``navlog.campaign.spec``), runs each as an isolated, resumable job on the fleet executors
  (``navlog.campaign.runner``), and writes the statistics (``navlog.campaign.stats``) and reports
  (``navlog.campaign.report``);
- ``load_campaign``: the typed, checked campaign file;
- ``run_campaign_case``: a campaign run for a ``navlog ci run`` case of kind campaign (its summary).

The campaign sits above the recorder (which runs a navigation) and the analysis (the executors and
the metrics). Names are imported on first use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.campaign.runner import CampaignResult, run_campaign, run_campaign_case
    from navlog.campaign.spec import CampaignSpec, load_campaign

__all__ = ["CampaignResult", "CampaignSpec", "load_campaign", "run_campaign", "run_campaign_case"]

_MODULES = {
    "CampaignResult": "runner",
    "run_campaign": "runner",
    "run_campaign_case": "runner",
    "CampaignSpec": "spec",
    "load_campaign": "spec",
}

__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
