"""Tests of gcs.core.multitarget (issue 25, many targets)."""
