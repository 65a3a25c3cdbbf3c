"""The names of a sensor's measured components (wang2012 eq. 4), in the order a measurement vector holds them."""

__all__ = ["RANGE", "AZIMUTH", "ELEVATION", "KNOWN_COMPONENTS"]

RANGE, AZIMUTH, ELEVATION = "range", "azimuth", "elevation"
KNOWN_COMPONENTS = (RANGE, AZIMUTH, ELEVATION)
