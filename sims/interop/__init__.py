"""Other tools running our scenarios: SSP export, libcosim and ecos, and the cross-engine comparison."""
