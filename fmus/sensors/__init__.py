"""Sensor models: a star tracker, a rate gyro and a magnetometer, sampled, with counter-based seeded noise."""
