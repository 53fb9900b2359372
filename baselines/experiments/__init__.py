"""The study's experiments (not contestants): pole and crawler claims, NAC, calibration."""
