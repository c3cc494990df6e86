"""Measured data formats: every way joint data arrive (CSV column layouts, ROS bags) turned into the
same tables of used columns (t, q, [dq], [ddq], tau) that ``measured.reading.raw_chunks`` yields.
The fit never knows the file format."""
