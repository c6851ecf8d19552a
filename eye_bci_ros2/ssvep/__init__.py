"""Pure SSVEP core: EEG layouts, filters, references, decoders, decisions, stimuli."""
