"""Reading the input: the annotation file (format v1), the drawing and scribble layers."""
