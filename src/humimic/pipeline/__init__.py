"""The simulation loop and the plumbing between stages (a one-way bus of timestamped values)."""
