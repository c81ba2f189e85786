"""Physical models as pure functions (standard library only: these modules run inside the FMUs)."""
