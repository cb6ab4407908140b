"""EHA flow balance (placeholder until the pump-side balance lands)."""

CHANNELS = ("p1", "p2", "x", "speed", "pa", "pb")
