"""The plant models: the seed papers' spacecraft and the user's rigid spacecraft, each a
:class:`~satfmu.fmus.model.Model`.
"""
