"""The robot: the one state machine (decide, dwell, redirect, faults) of every runtime."""
