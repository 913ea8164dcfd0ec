"""robocourse.bus.zenoh: the bus across processes and machines, in rmw_zenoh's wire format."""
