"""The user tools: the demo, the rosbag2 recorder, the tracking plot (benchmarks and checks live outside the package)."""
