"""Wire-harness jobs (thesis 7.3): boards, two-phase planning, insertion and tensioning."""
