"""boards/qla1."""
