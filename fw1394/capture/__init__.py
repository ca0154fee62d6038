"""fw1394.capture."""
