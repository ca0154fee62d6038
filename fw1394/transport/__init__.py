"""fw1394.transport."""
