"""Training side: reading datasets and (later) the networks. Never imports Mitsuba."""
