"""Sound: reading a take's audio, its features on the 100 Hz clock, speech activity (Silero VAD)
over a take and as audio arrives."""
