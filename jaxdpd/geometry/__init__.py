"""Geometry: periodic, sheared and elongated boxes, flows, neighbour lists, placement."""
