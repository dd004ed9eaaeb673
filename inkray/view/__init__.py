"""Looking at a relief: rasterization, shading, stereo and GI renders."""
