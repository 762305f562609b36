"""Leg controllers for the spined quadruped (simulation side)."""
