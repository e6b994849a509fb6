"""Families the question parser's corpus adds to the dataset templates (occlusion of objects, pose and
occlusion counts, part counts); dataset builds do not use them."""
