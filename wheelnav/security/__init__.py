"""Securing a chair's fleet: credentials (``wheelnav security``) and the router's rules."""
