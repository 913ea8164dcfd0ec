"""robocourse.launch: ROS 2 launch files (``launch`` + ``launch_ros``) for the in-process bus.

A launch file is Python that returns a description; ``launch()`` is ``ros2 launch``::

    from robocourse.launch import (DeclareLaunchArgument, IfCondition, LaunchConfiguration,
                                   LaunchDescription, Node, launch)

    def generate_launch_description():
        return LaunchDescription([
            DeclareLaunchArgument("params_file", default_value="mycar.yaml"),
            Node(package="mycar", executable="driver_node", namespace="mycar",
                 parameters=[LaunchConfiguration("params_file")],
                 remappings=[("cmd_vel", "cmd_vel_safe")]),
        ])

    system = launch(generate_launch_description(), launch_arguments={"params_file": "my.yaml"})
    system.executor.spin_for(1.0)

Same names and rules as upstream: a ``Node`` action passes its name, namespace, remappings and
parameters to the node as ``--ros-args`` (``-r __node:=``, ``-r __ns:=``, ``-r from:=to``,
``--params-file``; a dict of parameters becomes a parameter file, as launch_ros writes one), so
the node applies them exactly as :mod:`robocourse.bus.arguments` says. Substitutions
(``LaunchConfiguration``) resolve at launch time; a string from a substitution used as a
parameter value is read as YAML (launch_ros's ``ParameterValue`` default). Differences: the nodes
are objects in this process on one executor, not processes (``executable`` names a registered
factory: a package lists its executables in the ``robocourse.executables`` entry-point group, as
an ament_python package lists ``console_scripts``); ``launch()`` raises ``LaunchError`` naming
the action when a node cannot start (ros2 launch would log the process's death and carry on).
"""

from .actions import (
    Condition,
    DeclareLaunchArgument,
    IfCondition,
    LaunchConfiguration,
    LaunchDescription,
    Node,
    UnlessCondition,
)
from .runner import LaunchedSystem, LaunchError, executables, launch, show_args

__all__ = ["Condition", "DeclareLaunchArgument", "IfCondition", "LaunchConfiguration", "LaunchDescription",
           "LaunchError", "LaunchedSystem", "Node", "UnlessCondition", "executables", "launch", "show_args"]
