"""Support code of the test suite (no tests here)."""
