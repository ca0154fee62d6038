"""boards/memory."""
