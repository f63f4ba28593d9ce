// Placeholder: tests arrive with the implementation.
