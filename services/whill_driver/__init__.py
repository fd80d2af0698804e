"""The WHILL Model CR base driver: cmd_vel to the chair, wheel odometry and its condition back."""
