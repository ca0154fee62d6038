"""capture/views."""
