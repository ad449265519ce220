"""The spacecraft's environment: the geomagnetic field along its orbit (IGRF)."""
