"""Campaigns: scenarios x seeds x faults x lighting, run on Dask distributed (issue 22)."""

from quadmission.campaigns.matrix import Campaign, Cell, load_campaign, parse_campaign
from quadmission.campaigns.runner import CampaignResult, run_campaign

__all__ = ["Campaign", "CampaignResult", "Cell", "load_campaign", "parse_campaign",
           "run_campaign"]
