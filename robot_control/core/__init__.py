"""The control core: the per-tick controller, its references, integral and guards (no rclpy)."""
