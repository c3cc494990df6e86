"""The one pass over the data: roles of the samples, design rows, slot columns, kept samples, the reading thread."""
