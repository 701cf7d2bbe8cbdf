"""The problem file: its YAML read with limits (yaml_text), its keys declared once (keys), loaded
strictly (loader), described as a JSON Schema (schema), a reference page (reference) and a
commented starting file (starter)."""
