"""The ROS 2 layer: the controller node, its parameters, message conversions, QoS and spinning."""
