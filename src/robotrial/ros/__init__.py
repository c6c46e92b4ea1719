"""Nodes (layer 4): the in-process bus, rosbridge, and adapters onto it."""
