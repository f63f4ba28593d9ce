-- The role and the database robocal-server uses on PostgreSQL (docs/scaling.md). Run once, as a superuser:
--   sudo -u postgres psql -v ON_ERROR_STOP=1 < deploy/postgresql-setup.sql
-- robocal-server creates and migrates its tables itself at start; nothing else is needed here.

-- A login role that can create nothing outside its own database: no superuser, no CREATEDB, no CREATEROLE
-- (the defaults). Instances on this host log in over the Unix socket with peer authentication and need no
-- password; for instances on other hosts give it one, interactively so it stays out of shell history:
--   sudo -u postgres psql -c '\password robocal'
CREATE ROLE robocal LOGIN;

-- The database belongs to robocal, and with it the schema public (PostgreSQL 15 and later give public to the
-- database owner), so robocal owns its schema and may create, alter and drop its tables.
-- Collation "C" compares text by its bytes. The server declares its id columns COLLATE "C" itself (lists and
-- page tokens then follow the byte order SQLite uses; a language collation orders `-`, `.` and `_` otherwise,
-- ICU's en as a_b, a-c, a.d where the bytes give a-c, a.d, a_b); for the database as a whole it keeps every
-- other text index, such as the one behind the unique (campaign_id, request_id), independent of the operating
-- system's or ICU's collation tables, whose order can change with an upgrade and silently corrupt an index.
-- template0, because template1 may carry another collation.
CREATE DATABASE robocal OWNER robocal ENCODING 'UTF8' LC_COLLATE 'C' LC_CTYPE 'C' TEMPLATE template0;

-- Only robocal (and superusers) may connect.
REVOKE ALL ON DATABASE robocal FROM PUBLIC;

-- Timeouts for robocal's sessions only, so that an administrator's pg_dump, VACUUM or index build is not cut
-- (reasons in deploy/postgresql-robocal.conf). They apply to sessions opened after this, so restart the
-- instances if they already run.
ALTER ROLE robocal IN DATABASE robocal SET idle_in_transaction_session_timeout = '60s';
ALTER ROLE robocal IN DATABASE robocal SET statement_timeout = '60s';
-- synchronous_commit is not set per role, so that a cluster's remote_apply (postgresql-robocal.conf) applies
-- to robocal too; the server raises a session found at `off` to `on` itself.
