"""Target motion models (wang2012 eq. 2) and sensor models (wang2012 eq. 3-4)."""
