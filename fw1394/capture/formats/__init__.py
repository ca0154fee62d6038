"""capture/formats."""
