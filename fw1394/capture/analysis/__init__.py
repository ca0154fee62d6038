"""capture/analysis."""
