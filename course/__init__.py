"""Course material and the instructor's tools (release, grading, demo)."""
