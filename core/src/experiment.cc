// Placeholder: implemented with the identification issue.
