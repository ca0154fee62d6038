"""fw1394.fuzz."""
