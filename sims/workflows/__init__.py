"""The per-method workflows: analyses of a design, detumbling campaigns, the DEMETER loops and studies."""
