"""Campaign reports (``millfoil report``): a static HTML page with figures and tables from the store."""
