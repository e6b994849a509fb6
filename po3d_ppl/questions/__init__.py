"""Questions: the reference executor, the templates, the question generator and the dataset builder."""
