"""The pure OpenCV marker pipeline that measures a tool in a camera image (no Drake)."""
