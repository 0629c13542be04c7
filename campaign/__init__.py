"""Campaigns: many forward simulations over a parameter design, run in parallel into a resumable
store under ``runs/<name>/`` (docs/architecture.md, "Results on disk")."""

import lazy_loader as lazy

__getattr__, __dir__, __all__ = lazy.attach(
    __name__,
    submod_attrs={
        "designs": ["Design", "design_from_option", "paper_grid", "space_filling"],
        "errors": ["CampaignError", "DesignError", "DiskFullError"],
        "spec": ["CampaignSpec"],
        "store": ["CampaignStore"],
        "loader": ["CampaignData", "StoredResponses", "force_table", "load_campaign", "open_campaign"],
        "runner": ["run_campaign", "run_named_campaign"],
    },
)
