"""twmr.ros2: ROS 2 topics as ports, over DDS without a ROS installation (`docs/ros2.md`).

ROS 2's default middleware is DDS: a topic `/cmd_vel` of type `geometry_msgs/msg/Twist` is the DDS
topic `rt/cmd_vel` of type `geometry_msgs::msg::dds_::Twist_`, its samples in CDR. `messages`
builds those DDS types from the message definitions `rosbags` carries; `participant` keeps one
DDS participant per domain for the run; `blocks` has `ros2_topic` and `ros2_clock`.
"""
