"""What the dead-code check (vulture, `make test`) is told is used: entry points and
interfaces called from outside the code it reads (rclpy, python-can, pytest, plug-in authors),
and message or result fields written for others. Add a name only with its reason."""
# ruff: noqa

_.bus_error  # kept on the network for whoever looks at a lost bus (canopen_drive._BusLost)
_.on_message_received  # python-can's Listener interface
_.connection_made  # asyncio's Protocol interface (the emulated DAQ's server)
_.connection_lost  # asyncio's Protocol interface
_.data_received  # asyncio's Protocol interface
_.on_error  # python-can's Listener and rclpy's lifecycle callbacks
_.RESPONSE_TIMEOUT  # canopen's SDO client setting
_.unraisablehook  # sys hook set on interrupt
worker  # JobResult field: where a job ran
_.from_settings  # the plug-in authors' constructor (examples/, docs)
step_v  # a protocol setting read through the settings framework
STEPPINGS  # mypy checks each is a Stepping
_._parameter_service  # rclpy's parameter service, kept alive
_.on_configure  # rclpy's lifecycle callbacks
_.on_activate  # rclpy's lifecycle callbacks
_.on_deactivate  # rclpy's lifecycle callbacks
_.on_cleanup  # rclpy's lifecycle callbacks
_.on_shutdown  # rclpy's lifecycle callbacks
_._frame_id  # message slots filled without their setters
_._x  # message slots filled without their setters
_._y  # message slots filled without their setters
_._z  # message slots filled without their setters
_._torque  # message slots filled without their setters
_._wrench  # message slots filled without their setters
_._check_fields  # message slots filled without their setters
_.floating_point_range  # ROS ParameterDescriptor fields
_.integer_range  # ROS ParameterDescriptor fields
muscle_contraction_m  # a result field read by its users
rms_contraction_m  # a result field read by its users
_.maxdict  # reprlib's limits
_.maxlevel  # reprlib's limits
_.maxlist  # reprlib's limits
_.maxtuple  # reprlib's limits
_.maxlong  # reprlib's limits
_.maxother  # reprlib's limits
_.maxstring  # reprlib's limits
pytestmark  # pytest's module marks
pytest_configure  # pytest's hook
core_restored  # an autouse fixture
_.server_info  # the test client keeps what the server said
_.closed_by_server  # the test client keeps what the server said
_.__qualname__  # the kernel's entry point named as the kernel (models.jit)
pytest_collection_modifyitems  # pytest's hook
polynomials  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
model_comparison_by_branch  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
model_comparison_length_m  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
timing_s  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
inverse_model  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
forward_model_rms_N  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
correlation  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
rms_before  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
law_zoo  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
start_from  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
rms_error  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
max_error  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
error_at_reversal  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
error_elsewhere  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
reversal_window_s  # a TypedDict key, read by its string (summary.json, metrics.json, --json)
