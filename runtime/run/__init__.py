"""One run: the loop driver (:mod:`.simulate`), the results it records and writes
(:mod:`.results`, :mod:`.output`, :mod:`.atomic`), the force filter and the memory estimate."""
