"""The contact phase: the loops over joints and pairs and their cached instances, the contact
model and the read-only view a component sees (``contacts_view``), joints, dampers, the
stable step, stress and what follows a change of the ice. A contact law's contract is
``siku_core.contact_law``.
"""
