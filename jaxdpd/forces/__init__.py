"""Forces: pair laws and their sums, bond laws, spring–spring repulsion, body forces."""
