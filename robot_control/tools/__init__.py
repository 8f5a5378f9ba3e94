"""Tools around the package: the demo, benchmarks, the rosbag2 recorder, plots, README generators."""
