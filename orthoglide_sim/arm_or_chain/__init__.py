"""A simulated robot by name, serial arm or closed chain: the room above arms/ and chains/ that
chooses between them (bags, exciting-trajectory design, the tick-by-tick session), so that
arms/ never imports chains/."""
