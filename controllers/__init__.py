"""Controller laws (runtime side), their artifacts and their FMU definitions."""
