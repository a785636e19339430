"""Point-cloud readers and writers (being written; see README)."""
