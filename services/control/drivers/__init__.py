"""Servo drivers of the control interface, chosen by a typed configuration."""
