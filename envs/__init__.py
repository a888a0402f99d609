"""The scenario files shipped with azgym (installed as the package ``azgym.site.scenarios``)."""
