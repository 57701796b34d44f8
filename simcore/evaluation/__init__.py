"""Quality evaluations of the pipeline stages over directories of rigged assets."""
