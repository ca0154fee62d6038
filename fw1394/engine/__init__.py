"""fw1394.engine."""
