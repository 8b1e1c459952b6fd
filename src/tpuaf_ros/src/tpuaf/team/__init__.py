"""The team layer: typed team messages, their checks, liveness, the bus and the relay."""
