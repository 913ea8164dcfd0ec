"""robocourse.control.hardware: what ros2_control's ``hardware_interface`` package holds.

- ``types``: return_type, CallbackReturn, lifecycle states, standard interface names;
- ``info``: HardwareInfo from a URDF's ``<ros2_control>`` (upstream's parser errors + line + fix);
- ``component``: SystemInterface / ActuatorInterface / SensorInterface and their lifecycle wrapper;
- ``mock_components``: mock_components/GenericSystem;
- ``mujoco_system``: robocourse/MujocoSystem (the shipped robots simulated in MuJoCo);
- ``modular``: robocourse/RRBotModularJoint (an actuator per joint, demos' example 6) and
  robocourse/ForceTorqueSensor (an external sensor, demos' example 5).
"""
