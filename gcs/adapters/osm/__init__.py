"""Cities from OpenStreetMap: ``gcs scenario from-osm`` (docs/osm.md).

Read with pyosmium (the optional extra ``osm``), imported only when a file is read:

* :mod:`.reading` -- the extract's buildings, highway ways, extent and date, in one pass;
* :mod:`.heights` -- a building's roof height from ``height``, ``building:levels`` or the default;
* :mod:`.clipping` -- ways cut to the box;
* :mod:`.road_network` -- the drivable roads, junction to junction, strongly connected;
* :mod:`.city_files` -- the buildings' and roads' GeoJSON, with the attribution;
* :mod:`.scenario_text` -- the scenario TOML;
* :mod:`.importer` -- all of it for one extract and box; :mod:`.command` -- the command line.
"""
