"""Controllers (ros2_controllers), one folder each with its parameter schema beside the code.

Declared to :mod:`robocourse.control.pluginlib` under upstream's names, e.g.
``forward_command_controller/ForwardCommandController``,
``position_controllers/JointGroupPositionController``,
``joint_state_broadcaster/JointStateBroadcaster``.
"""
