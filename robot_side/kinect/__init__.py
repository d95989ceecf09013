"""Kinect (v1) depth camera source on libfreenect; publishes DepthImage / CameraInfo as the simulator does."""
