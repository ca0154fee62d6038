"""boards/snake2010."""
