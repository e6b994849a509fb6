"""Question templates in the public JSON format (package data; see docs/questions.md)."""
