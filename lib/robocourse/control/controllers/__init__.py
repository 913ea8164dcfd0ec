"""Controllers (ros2_controllers), one folder each with its parameter schema beside the code.

Declared to :mod:`robocourse.control.pluginlib` under upstream's names, e.g.
``forward_command_controller/ForwardCommandController``,
``position_controllers/JointGroupPositionController``,
``joint_state_broadcaster/JointStateBroadcaster``,
``joint_trajectory_controller/JointTrajectoryController``,
``parallel_gripper_action_controller/GripperActionController``,
``admittance_controller/AdmittanceController`` (chainable),
``diff_drive_controller/DiffDriveController``, ``pid_controller/PidController`` (chainable).
Shared pieces: :mod:`.control_toolbox` (the PID) and :mod:`.realtime_goal` (action goals
between update() and the controller's node).
"""
