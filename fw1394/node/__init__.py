"""fw1394.node."""
